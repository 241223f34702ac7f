#include "hdeform/deformation_field.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace hdeform {
namespace {

constexpr std::size_t kGrain = 2048;

Eigen::Quaterniond unit_or_identity(const Eigen::Vector4d& wxyz) {
  const double norm = wxyz.norm();
  if (!(norm > 1e-12)) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(wxyz(0) / norm, wxyz(1) / norm, wxyz(2) / norm, wxyz(3) / norm);
}

}  // namespace

DeformationField blend_field(const Eigen::VectorXd& h, const HandleTransform& handle) {
  DeformationField field;
  field.rotation.resize(h.size(), 4);
  field.scale.resize(h.size());
  for (Eigen::Index v = 0; v < h.size(); ++v) {
    const auto q = blend_rotation(handle, h(v));
    field.rotation.row(v) << q.w(), q.x(), q.y(), q.z();
    field.scale(v) = blend_scale(handle, h(v));
  }
  return field;
}

Eigen::Quaterniond interpolated_rotation(const InterpolatedValue& value) { return unit_or_identity(value.head<4>().transpose()); }

InterpolatedValue interpolation_value(const HandleTransform& handle) {
  const auto q = handle.rotation();
  return (InterpolatedValue() << q.w(), q.x(), q.y(), q.z(), handle.scale).finished();
}

DeformationField interpolate_field(const DirichletSystem& system, const VertexPartition& partition,
                                   std::span<const HandleTransform> handles) {
  Eigen::MatrixXd values(static_cast<Eigen::Index>(partition.role.size()), kInterpolatedComponents);
  for (std::size_t v = 0; v < partition.role.size(); ++v) {
    const bool handle = partition.role[v] == VertexRole::Handle;
    values.row(static_cast<Eigen::Index>(v)) =
        handle ? interpolation_value(handles[static_cast<std::size_t>(partition.handle_index[v])]) : identity_interpolation_value();
  }
  system.solve(values);
  DeformationField field;
  field.rotation.resize(values.rows(), 4);
  field.scale = values.col(4);
  for (Eigen::Index v = 0; v < values.rows(); ++v) {
    const auto q = unit_or_identity(values.row(v).head<4>().transpose());
    field.rotation.row(v) << q.w(), q.x(), q.y(), q.z();
  }
  return field;
}

Eigen::Matrix3d AxialMaps::matrix(std::size_t triangle) const {
  const Eigen::Vector3d& c = coefficients[triangle];
  Eigen::Matrix3d cross;
  cross << 0.0, -axis.z(), axis.y(), axis.z(), 0.0, -axis.x(), -axis.y(), axis.x(), 0.0;
  return c(0) * Eigen::Matrix3d::Identity() + c(1) * cross + c(2) * axis * axis.transpose();
}

void sample_blend_maps(const Eigen::VectorXd& triangle_h, const HandleTransform& handle, AxialMaps& maps) {
  // Table of cos, sin at φ_i = i·θ/N with steps of at most 0.01 rad; the remainder δ of h·θ is
  // below 0.005 rad, where the Taylor terms below are exact to double precision.
  constexpr double kTableStep = 0.01;
  const double theta = handle.angle;
  const int intervals = std::max(16, static_cast<int>(std::ceil(std::abs(theta) / kTableStep)));
  maps.angle_table.resize(static_cast<std::size_t>(intervals) + 1);
  for (int i = 0; i <= intervals; ++i) {
    const double phi = theta * i / intervals;
    maps.angle_table[static_cast<std::size_t>(i)] = {std::cos(phi), std::sin(phi)};
  }
  maps.axis = handle.axis;
  maps.coefficients.resize(static_cast<std::size_t>(triangle_h.size()));
  const double step = theta / intervals;
  const double scale_slope = handle.scale - 1.0;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, maps.coefficients.size(), kGrain), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const double h = triangle_h(static_cast<Eigen::Index>(t));
      const double position = std::clamp(h, 0.0, 1.0) * intervals;
      const int i = static_cast<int>(position + 0.5);
      const double delta = (h * intervals - i) * step;
      const double d2 = delta * delta;
      constexpr double k1_6 = 1.0 / 6.0, k1_20 = 1.0 / 20.0, k1_42 = 1.0 / 42.0, k1_12 = 1.0 / 12.0, k1_30 = 1.0 / 30.0;
      const double sin_delta = delta * (1.0 - d2 * k1_6 * (1.0 - d2 * k1_20 * (1.0 - d2 * k1_42)));
      const double cos_delta = 1.0 - 0.5 * d2 * (1.0 - d2 * k1_12 * (1.0 - d2 * k1_30));
      const Eigen::Vector2d& base = maps.angle_table[static_cast<std::size_t>(i)];
      const double cosine = base(0) * cos_delta - base(1) * sin_delta;
      const double sine = base(1) * cos_delta + base(0) * sin_delta;
      const double s = 1.0 + h * scale_slope;
      maps.coefficients[t] = {s * cosine, s * sine, s * (1.0 - cosine)};
    }
  });
}

void sample_interpolated_maps(const Eigen::Matrix<double, Eigen::Dynamic, kInterpolatedComponents, Eigen::RowMajor>& components,
                              const Eigen::MatrixXi& triangles, std::vector<Eigen::Matrix3d>& maps) {
  maps.resize(static_cast<std::size_t>(triangles.rows()));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, maps.size(), kGrain), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const auto row = static_cast<Eigen::Index>(t);
      const Eigen::Matrix<double, 1, kInterpolatedComponents> mean =
          (components.row(triangles(row, 0)) + components.row(triangles(row, 1)) + components.row(triangles(row, 2))) / 3.0;
      maps[t] = mean(4) * unit_or_identity(mean.head<4>().transpose()).toRotationMatrix();
    }
  });
}

Eigen::VectorXd barycenter_values(const Eigen::VectorXd& vertex_values, const Eigen::MatrixXi& triangles) {
  return barycenter_values(Eigen::MatrixXd(vertex_values), triangles).col(0);
}

Eigen::MatrixXd barycenter_values(const Eigen::MatrixXd& vertex_values, const Eigen::MatrixXi& triangles) {
  Eigen::MatrixXd values(triangles.rows(), vertex_values.cols());
  // Column by column: a column of the vertex values stays in cache while its triangles gather
  // from it (row by row, 124 marker columns cost a cache miss per corner and column).
  tbb::parallel_for(Eigen::Index{0}, vertex_values.cols(), [&](Eigen::Index c) {
    const auto corners = vertex_values.col(c);
    auto column = values.col(c);
    for (Eigen::Index t = 0; t < triangles.rows(); ++t) column(t) = (corners(triangles(t, 0)) + corners(triangles(t, 1)) + corners(triangles(t, 2))) / 3.0;
  });
  return values;
}

}  // namespace hdeform

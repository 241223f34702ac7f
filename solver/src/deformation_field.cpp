#include "hdeform/deformation_field.h"

#include <tbb/parallel_for.h>

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

void sample_blend_maps(const Eigen::VectorXd& triangle_h, const HandleTransform& handle, std::vector<Eigen::Matrix3d>& maps) {
  maps.resize(static_cast<std::size_t>(triangle_h.size()));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, maps.size(), kGrain), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const double h = triangle_h(static_cast<Eigen::Index>(t));
      maps[t] = blend_scale(handle, h) * blend_rotation(handle, h).toRotationMatrix();
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
  Eigen::VectorXd values(triangles.rows());
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    values(t) = (vertex_values(triangles(t, 0)) + vertex_values(triangles(t, 1)) + vertex_values(triangles(t, 2))) / 3.0;
  }
  return values;
}

}  // namespace hdeform

#include "hdeform/deformation_field.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "lanes.h"
#include "target_clones.h"

namespace hdeform {
namespace {

constexpr std::size_t kGrain = 2048;

// An interpolated quaternion no longer than this (or NaN) stands for no rotation.
constexpr double kSmallestQuaternionNorm = 1e-12;

Eigen::Quaterniond unit_or_identity(const Eigen::Vector4d& wxyz) {
  const double norm = wxyz.norm();
  if (!(norm > kSmallestQuaternionNorm)) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(wxyz(0) / norm, wxyz(1) / norm, wxyz(2) / norm, wxyz(3) / norm);
}

// The angle table of sample_blend_maps: (cos, sin) pairs at `intervals` + 1 angles `step` apart.
struct BlendTable {
  const Eigen::Vector2d* cos_sin;
  double intervals;
  double step;
  double scale_slope;
};

// (α, β, γ) = s (cos hθ, sin hθ, 1 − cos hθ) with s = 1 + h (scale − 1), for the triangles
// [begin, end): four at a time in SIMD lanes, a short last group padded; each lane's arithmetic is
// the per-triangle formula's, so the bits are those of one triangle at a time.
HDEFORM_TARGET_CLONES("avx2", "default")
void blend_coefficients(const BlendTable& table, const double* h_values, std::size_t begin, std::size_t end, Eigen::Vector3d* coefficients) {
  using detail::Lanes4;
  using Ints4 = int __attribute__((vector_size(16)));
  constexpr double k1_6 = 1.0 / 6.0, k1_20 = 1.0 / 20.0, k1_42 = 1.0 / 42.0, k1_12 = 1.0 / 12.0, k1_30 = 1.0 / 30.0;
  for (std::size_t first = begin; first < end; first += 4) {
    const std::size_t count = std::min<std::size_t>(4, end - first);
    Lanes4 h = {};
    if (count == 4) {
      detail::load_lanes(h_values + first, h);
    } else {
      for (std::size_t k = 0; k < count; ++k) h[k] = h_values[first + k];
    }
    const Lanes4 zero = {}, one = zero + 1.0;
    const Lanes4 clamped = h < zero ? zero : (one < h ? one : h);  // std::clamp(h, 0, 1)
    const Ints4 nearest = __builtin_convertvector(clamped * table.intervals + 0.5, Ints4);
    const Lanes4 delta = (h * table.intervals - __builtin_convertvector(nearest, Lanes4)) * table.step;
    const Lanes4 d2 = delta * delta;
    const Lanes4 sin_delta = delta * (1.0 - d2 * k1_6 * (1.0 - d2 * k1_20 * (1.0 - d2 * k1_42)));
    const Lanes4 cos_delta = 1.0 - 0.5 * d2 * (1.0 - d2 * k1_12 * (1.0 - d2 * k1_30));
    const Eigen::Vector2d* at[4] = {table.cos_sin + nearest[0], table.cos_sin + nearest[1], table.cos_sin + nearest[2], table.cos_sin + nearest[3]};
    const Lanes4 base_cos = {(*at[0])(0), (*at[1])(0), (*at[2])(0), (*at[3])(0)};
    const Lanes4 base_sin = {(*at[0])(1), (*at[1])(1), (*at[2])(1), (*at[3])(1)};
    const Lanes4 cosine = base_cos * cos_delta - base_sin * sin_delta;
    const Lanes4 sine = base_sin * cos_delta + base_cos * sin_delta;
    const Lanes4 s = 1.0 + h * table.scale_slope;
    const Lanes4 alpha = s * cosine, beta = s * sine, gamma = s * (1.0 - cosine);
    for (std::size_t k = 0; k < count; ++k) coefficients[first + k] = {alpha[k], beta[k], gamma[k]};
  }
}

// T_t = s R(q) from the mean of the corners' interpolated (q0..q3, s), for the triangles
// [begin, end): four at a time in SIMD lanes, a lane per triangle, a short last group padded. Each
// lane's arithmetic is that of the per-triangle code (the mean, unit_or_identity with Eigen's
// norm of a 4-vector, Eigen's toRotationMatrix, the scale), so the bits are the same.
HDEFORM_TARGET_CLONES("avx2", "default")
void interpolated_maps(const double* components, const Eigen::MatrixXi& triangles, std::size_t begin, std::size_t end, Eigen::Matrix3d* maps) {
  using detail::Lanes4;
  for (std::size_t first = begin; first < end; first += 4) {
    const std::size_t count = std::min<std::size_t>(4, end - first);
    // Each lane's corners (a padded lane repeats the group's first triangle; it is not stored).
    const double* corner[3][4];
    for (int k = 0; k < 3; ++k) {
      for (std::size_t lane = 0; lane < 4; ++lane) {
        const auto t = static_cast<Eigen::Index>(first + (lane < count ? lane : 0));
        corner[k][lane] = components + kInterpolatedComponents * static_cast<std::size_t>(triangles(t, k));
      }
    }
    Lanes4 mean[kInterpolatedComponents];
    for (int c = 0; c < kInterpolatedComponents; ++c) {
      const Lanes4 a = {corner[0][0][c], corner[0][1][c], corner[0][2][c], corner[0][3][c]};
      const Lanes4 b = {corner[1][0][c], corner[1][1][c], corner[1][2][c], corner[1][3][c]};
      const Lanes4 d = {corner[2][0][c], corner[2][1][c], corner[2][2][c], corner[2][3][c]};
      mean[c] = ((a + b) + d) / 3.0;
    }
    const Lanes4 &w = mean[0], &x = mean[1], &y = mean[2], &z = mean[3], &scale = mean[4];
    // Eigen sums a 4-vector's squares in two pairs of lanes, (w² + y²) + (x² + z²).
    const Lanes4 squared = (w * w + y * y) + (x * x + z * z);
    Lanes4 norm;
    for (int lane = 0; lane < 4; ++lane) norm[lane] = std::sqrt(squared[lane]);
    const auto unit = norm > kSmallestQuaternionNorm;  // false for NaN too: unit_or_identity's identity
    const Lanes4 zero = {}, one = zero + 1.0;
    const Lanes4 qw = unit ? w / norm : one, qx = unit ? x / norm : zero, qy = unit ? y / norm : zero, qz = unit ? z / norm : zero;
    const Lanes4 tx = 2.0 * qx, ty = 2.0 * qy, tz = 2.0 * qz;
    const Lanes4 twx = tx * qw, twy = ty * qw, twz = tz * qw;
    const Lanes4 txx = tx * qx, txy = ty * qx, txz = tz * qx;
    const Lanes4 tyy = ty * qy, tyz = tz * qy, tzz = tz * qz;
    // Column-major, as Matrix3d stores it.
    const Lanes4 entry[9] = {scale * (1.0 - (tyy + tzz)), scale * (txy + twz), scale * (txz - twy),
                             scale * (txy - twz), scale * (1.0 - (txx + tzz)), scale * (tyz + twx),
                             scale * (txz + twy), scale * (tyz - twx), scale * (1.0 - (txx + tyy))};
    for (std::size_t lane = 0; lane < count; ++lane) {
      double* out = maps[first + lane].data();
      for (int e = 0; e < 9; ++e) out[e] = entry[e][lane];
    }
  }
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
  // below 0.005 rad, where the Taylor terms of blend_coefficients are exact to double precision.
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
  const BlendTable table{maps.angle_table.data(), static_cast<double>(intervals), theta / intervals, handle.scale - 1.0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, maps.coefficients.size(), kGrain), [&](const tbb::blocked_range<std::size_t>& range) {
    blend_coefficients(table, triangle_h.data(), range.begin(), range.end(), maps.coefficients.data());
  });
}

void sample_interpolated_maps(const Eigen::Matrix<double, Eigen::Dynamic, kInterpolatedComponents, Eigen::RowMajor>& components,
                              const Eigen::MatrixXi& triangles, std::vector<Eigen::Matrix3d>& maps) {
  maps.resize(static_cast<std::size_t>(triangles.rows()));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, maps.size(), kGrain), [&](const tbb::blocked_range<std::size_t>& range) {
    interpolated_maps(components.data(), triangles, range.begin(), range.end(), maps.data());
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

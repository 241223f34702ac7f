#include "hdeform/rotation_fit.h"

#include <Eigen/SVD>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "rotation_newton.h"
#include "target_clones.h"

namespace hdeform {
namespace rotation_lanes {
namespace {

RotationFit fit_one(const Eigen::Matrix3d& a, const Eigen::Matrix3d& start, double tolerance, int max_steps) {
  const Matrix3<double> lane_a = from_eigen(a);
  const LaneFit<double> lane = newton(lane_a, from_eigen(start), tolerance, max_steps);
  RotationFit fit{to_eigen(lane.rotation), lane.objective, 0, false};
  fit.steps = static_cast<int>(lane.steps);
  if (lane.needs_svd) finish_with_svd(a, fit);
  return fit;
}

// Compiled twice, for AVX2 and for the baseline (where each four-lane operation is two SSE2 ones);
// the loader picks the one the CPU runs. AVX2 alone brings no FMA, so both give the same bits.
HDEFORM_TARGET_CLONES("avx2", "default")
void fit_lanes(const Eigen::Matrix3d* a, const Eigen::Matrix3d* start, RotationFit* fits, std::size_t count, double tolerance, int max_steps) {
  std::size_t first = 0;
  for (; first + kLanes <= count; first += kLanes) {
    Matrix3<Lanes> lane_a{}, lane_start{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        lane_a.m[i][j] = Lanes{a[first](i, j), a[first + 1](i, j), a[first + 2](i, j), a[first + 3](i, j)};
        lane_start.m[i][j] = Lanes{start[first](i, j), start[first + 1](i, j), start[first + 2](i, j), start[first + 3](i, j)};
      }
    }
    const LaneFit<Lanes> lanes = newton(lane_a, lane_start, tolerance, max_steps);
    for (int lane = 0; lane < kLanes; ++lane) {
      RotationFit& fit = fits[first + lane];
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) fit.rotation(i, j) = lanes.rotation.m[i][j][lane];
      }
      fit.objective = lanes.objective[lane];
      fit.steps = static_cast<int>(lanes.steps[lane]);
      fit.fell_back_to_svd = false;
      if (lanes.needs_svd[lane] != 0) finish_with_svd(a[first + lane], fit);
    }
  }
  for (; first < count; ++first) fits[first] = fit_one(a[first], start[first], tolerance, max_steps);
}

}  // namespace
}  // namespace rotation_lanes

using rotation_lanes::fit_lanes;
using rotation_lanes::fit_one;

Eigen::Matrix3d closest_rotation_svd(const Eigen::Matrix3d& a) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d v = svd.matrixV();
  if ((u * v.transpose()).determinant() < 0.0) u.col(2) = -u.col(2);
  return u * v.transpose();
}

Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& nearly_rotation) {
  return Eigen::Quaterniond(nearly_rotation).normalized().toRotationMatrix();
}

RotationFit fit_rotation(const Eigen::Matrix3d& a, const Eigen::Matrix3d& start, double tolerance, int max_steps) {
  return fit_one(a, start, tolerance, max_steps);
}

void fit_rotations(std::span<const Eigen::Matrix3d> a, std::span<const Eigen::Matrix3d> start, std::span<RotationFit> fits, double tolerance,
                   int max_steps) {
  if (start.size() != a.size() || fits.size() != a.size()) {
    throw std::invalid_argument("fit_rotations: " + std::to_string(a.size()) + " matrices, " + std::to_string(start.size()) + " starts and " +
                                std::to_string(fits.size()) + " results");
  }
  fit_lanes(a.data(), start.data(), fits.data(), a.size(), tolerance, max_steps);
}

}  // namespace hdeform


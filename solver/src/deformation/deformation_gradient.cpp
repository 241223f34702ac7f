#include "hdeform/deformation_gradient.h"

#include "hdeform/errors.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>

#include <tbb/parallel_for.h>

namespace hdeform {
namespace {

// The edge frame [v2−v1, v3−v1, v4−v1]; false when the triangle has no area.
bool tetrahedron_frame(const Eigen::Vector3d& v1, const Eigen::Vector3d& v2, const Eigen::Vector3d& v3, Eigen::Matrix3d& frame) {
  const Eigen::Vector3d e1 = v2 - v1;
  const Eigen::Vector3d e2 = v3 - v1;
  const Eigen::Vector3d normal = e1.cross(e2);
  const double length = normal.norm();
  if (!(length > 0.0)) return false;
  frame.col(0) = e1;
  frame.col(1) = e2;
  frame.col(2) = normal / std::sqrt(length);
  return true;
}

}  // namespace

Eigen::Matrix3d deformation_gradient(const Eigen::Vector3d& v1, const Eigen::Vector3d& v2, const Eigen::Vector3d& v3,
                                     const Eigen::Vector3d& w1, const Eigen::Vector3d& w2, const Eigen::Vector3d& w3) {
  Eigen::Matrix3d rest;
  if (!tetrahedron_frame(v1, v2, v3, rest)) return Eigen::Matrix3d::Identity();
  Eigen::Matrix3d posed;
  if (!tetrahedron_frame(w1, w2, w3, posed)) {
    // A triangle collapsed in the pose: its edges still map exactly, the normal to nothing.
    posed.col(0) = w2 - w1;
    posed.col(1) = w3 - w1;
    posed.col(2).setZero();
  }
  return posed * rest.inverse();
}

void deformation_gradients(const Mesh& rest, const Eigen::MatrixXd& posed, std::vector<Eigen::Matrix3d>& gradients) {
  if (posed.rows() != rest.vertex_count() || posed.cols() != 3) {
    throw InputError("posed positions: " + std::to_string(posed.rows()) + "×" + std::to_string(posed.cols()) + " for a mesh of " +
                     std::to_string(rest.vertex_count()) + " vertices");
  }
  const auto count = static_cast<std::size_t>(rest.triangle_count());
  gradients.resize(count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 512), [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const auto i = static_cast<Eigen::Index>(t);
      const int a = rest.triangles(i, 0), b = rest.triangles(i, 1), c = rest.triangles(i, 2);
      gradients[t] = deformation_gradient(rest.positions.row(a).transpose(), rest.positions.row(b).transpose(), rest.positions.row(c).transpose(),
                                          posed.row(a).transpose(), posed.row(b).transpose(), posed.row(c).transpose());
    }
  });
}

RotationScale rotation_and_scale(const Eigen::Matrix3d& deformation) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(deformation, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();
  // det Q = ± the product of the singular values; a reflection's nearest rotation turns the
  // axis of the smallest singular value around.
  const double determinant = deformation.determinant();
  if ((u * v.transpose()).determinant() < 0.0) u.col(2) = -u.col(2);
  RotationScale result;
  result.rotation = Eigen::Quaterniond(Eigen::Matrix3d(u * v.transpose())).normalized();
  if (result.rotation.w() < 0.0) result.rotation.coeffs() = -result.rotation.coeffs();
  result.scale = std::cbrt(std::abs(determinant));
  return result;
}

}  // namespace hdeform

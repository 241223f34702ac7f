#include "hdeform/handle_transform.h"

#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <sstream>

#include "hdeform/errors.h"

namespace hdeform {
namespace {

// A map whose smallest singular value is below this fraction of its largest collapses space.
constexpr double kSingularRatio = 1e-9;

Eigen::AngleAxisd axis_angle_of(const Eigen::Matrix3d& rotation) {
  Eigen::AngleAxisd axis_angle(rotation);
  if (axis_angle.angle() == 0.0 || !axis_angle.axis().allFinite()) axis_angle.axis() = Eigen::Vector3d::UnitZ();
  return axis_angle;
}

}  // namespace

HandleTransform HandleTransform::from_affine(const Eigen::Matrix<double, 3, 4>& affine) {
  if (!affine.allFinite()) throw InputError("the transform has a non-finite entry");
  HandleTransform transform;
  transform.linear = affine.leftCols<3>();
  transform.translation = affine.col(3);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(transform.linear, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sigma = svd.singularValues();
  if (!(sigma(2) > kSingularRatio * sigma(0))) {
    std::ostringstream message;
    message << "the transform's 3×3 part is singular (singular values " << sigma(0) << ", " << sigma(1) << ", " << sigma(2) << ")";
    throw InputError(message.str());
  }
  if (transform.linear.determinant() < 0.0) throw InputError("the transform's 3×3 part is a reflection (negative determinant)");
  const Eigen::Matrix3d rotation = svd.matrixU() * svd.matrixV().transpose();
  transform.stretch = svd.matrixV() * sigma.asDiagonal() * svd.matrixV().transpose();
  transform.scale = std::cbrt(sigma.prod());
  const auto axis_angle = axis_angle_of(rotation);
  transform.axis = axis_angle.axis();
  transform.angle = axis_angle.angle();
  return transform;
}

HandleTransform HandleTransform::about_pivot(const Eigen::Vector3d& axis, const Eigen::Vector3d& pivot, double angle, double scale,
                                             const Eigen::Vector3d& shift) {
  if (!axis.allFinite() || !pivot.allFinite() || !shift.allFinite() || !std::isfinite(angle) || !std::isfinite(scale)) {
    throw InputError("the handle pose has a non-finite value");
  }
  if (!(axis.norm() > 0.0)) throw InputError("the rotation axis is zero");
  if (!(scale > 0.0)) throw InputError("the scale must be positive");
  HandleTransform transform;
  transform.kind = Kind::Pose;
  // Normalising an already unit axis could change its last bit; leave it, so that a pose read
  // back from a file is the pose that was written.
  const bool unit = std::abs(axis.squaredNorm() - 1.0) <= 4.0 * std::numeric_limits<double>::epsilon();
  transform.axis = unit ? axis : axis.normalized();
  transform.angle = angle;
  transform.scale = scale;
  transform.pivot = pivot;
  transform.shift = shift;
  transform.stretch = scale * Eigen::Matrix3d::Identity();
  transform.linear = scale * Eigen::AngleAxisd(angle, transform.axis).toRotationMatrix();
  transform.translation = pivot + shift - transform.linear * pivot;
  return transform;
}

HandleTransform HandleTransform::at_fraction(double fraction) const {
  if (fraction == 1.0) return *this;
  if (kind == Kind::Pose) return about_pivot(axis, pivot, fraction * angle, 1.0 + fraction * (scale - 1.0), fraction * shift);
  HandleTransform partial = *this;
  partial.angle = fraction * angle;
  partial.stretch = (1.0 - fraction) * Eigen::Matrix3d::Identity() + fraction * stretch;
  partial.scale = std::cbrt(partial.stretch.determinant());
  partial.linear = Eigen::AngleAxisd(partial.angle, axis).toRotationMatrix() * partial.stretch;
  partial.translation = fraction * translation;
  return partial;
}

Eigen::Quaterniond HandleTransform::rotation() const {
  Eigen::Quaterniond q(Eigen::AngleAxisd(angle, axis));
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  return q;
}

Eigen::Matrix<double, 3, 4> HandleTransform::affine() const {
  Eigen::Matrix<double, 3, 4> matrix;
  matrix << linear, translation;
  return matrix;
}

}  // namespace hdeform

#pragma once
// A handle's edit (paper §5): an affine map for the handle's vertices, split by polar
// decomposition A = R S into the rotation and the uniform scale that the field spreads over the
// region of interest.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hdeform {

struct HandleTransform {
  Eigen::Matrix3d linear = Eigen::Matrix3d::Identity();      // A: targets are A p + t
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();     // t
  Eigen::Matrix3d stretch = Eigen::Matrix3d::Identity();     // S (symmetric positive definite)
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();           // unit rotation axis of R
  double angle = 0.0;  // radians about `axis`: in [0, π] for an affine map, any value for a twist
  double scale = 1.0;  // cbrt(det S)
  bool twist = false;  // the field blends `angle` about the fixed axis instead of slerping
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();  // a twist's point on its axis

  static HandleTransform identity() { return {}; }

  // From a 3×4 matrix [A | t]. Throws InputError when A is not finite, singular, or a reflection.
  static HandleTransform from_affine(const Eigen::Matrix<double, 3, 4>& affine);

  // A rotation by `angle` (radians, several turns allowed) about the line through `point` along
  // `axis`, with a uniform scale about that line's point. Throws InputError for a zero axis or
  // non-positive scale.
  static HandleTransform twist_about(const Eigen::Vector3d& axis, const Eigen::Vector3d& point, double angle,
                                     double scale = 1.0);

  // The edit a fraction f ∈ [0, 1] of the way from the identity (a drag in progress): the angle
  // and the stretch grow linearly (a slerp of the rotation), the translation linearly; a twist
  // keeps its axis line. Returns this transform unchanged at f = 1.
  HandleTransform at_fraction(double fraction) const;

  Eigen::Vector3d apply(const Eigen::Vector3d& point) const { return linear * point + translation; }

  // R as a unit quaternion with w ≥ 0 (a twist's turns taken modulo a full turn).
  Eigen::Quaterniond rotation() const;

  // The 3×4 matrix [A | t].
  Eigen::Matrix<double, 3, 4> affine() const;
};

}  // namespace hdeform

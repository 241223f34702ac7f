#pragma once
/// @file
/// A handle's edit (paper §5): an affine map for the handle's vertices, split into the rotation and
/// the uniform scale that the field spreads over the region of interest. Two kinds:
///   affine: a 3×4 matrix [A | t]; polar decomposition A = R S gives R (angle in [0, π]) and
///           s = cbrt(det S);
///   pose:   a turn by any angle (several turns allowed) about the line through a pivot, a uniform
///           scale about the pivot, then a shift — what the editor's gizmo edits. The field blends
///           the angle itself, so a 720° twist turns the middle of a bar by 360°, where a matrix
///           could only say "no rotation".
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hdeform {

/// A handle's edit: an affine map of the handle's vertices and its split into a rotation (axis and
/// angle) and a uniform scale, which the field spreads. Make one with from_affine() or about_pivot().
struct HandleTransform {
  /// Affine: a matrix given as is; Pose: a twist, whose angle may exceed a turn.
  enum class Kind { Affine, Pose };

  Kind kind = Kind::Affine;
  Eigen::Matrix3d linear = Eigen::Matrix3d::Identity();   ///< A: targets are A p + t
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  ///< t
  Eigen::Matrix3d stretch = Eigen::Matrix3d::Identity();  ///< S (symmetric positive definite)
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();        ///< unit rotation axis of R
  double angle = 0.0;  ///< radians about `axis`: in [0, π] for an affine map, any value for a pose
  double scale = 1.0;  ///< cbrt(det S)
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();  ///< pose: the point the turn and scale keep
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  ///< pose: the translation applied after them

  /// The edit that moves nothing.
  static HandleTransform identity() { return {}; }

  /// From a 3×4 matrix [A | t]. Throws InputError when A is not finite, singular, or a reflection.
  static HandleTransform from_affine(const Eigen::Matrix<double, 3, 4>& affine);

  /// p ↦ pivot + shift + scale · R(axis, angle) (p − pivot). Throws InputError for a zero axis, a
  /// non-positive scale or a non-finite value.
  static HandleTransform about_pivot(const Eigen::Vector3d& axis, const Eigen::Vector3d& pivot, double angle, double scale = 1.0,
                                     const Eigen::Vector3d& shift = Eigen::Vector3d::Zero());

  /// The edit a fraction f ∈ [0, 1] of the way from the identity (a drag in progress): the angle
  /// and the stretch grow linearly (a slerp of the rotation), the translation linearly; a pose
  /// keeps its pivot. Returns this transform unchanged at f = 1.
  HandleTransform at_fraction(double fraction) const;

  /// The handle's target for a rest position: linear · p + translation.
  Eigen::Vector3d apply(const Eigen::Vector3d& point) const { return linear * point + translation; }
  /// Moves nothing: every point stays (a pose of whole turns with no shift or scale counts as
  /// moving, since the field turns the region between).
  bool is_identity() const { return angle == 0.0 && linear == Eigen::Matrix3d::Identity() && translation.isZero(0.0); }

  /// R as a unit quaternion with w ≥ 0 (a pose's turns taken modulo a full turn).
  Eigen::Quaterniond rotation() const;

  /// The 3×4 matrix [A | t].
  Eigen::Matrix<double, 3, 4> affine() const;
};

}  // namespace hdeform

#pragma once
/// @file
/// Deformation fields (paper §5 and §7): a rotation (unit quaternion) and a uniform scale per
/// vertex, identity at the sinks and the handle's own at its vertices, and the per-triangle maps
/// T_t = s_t R_t sampled at the barycenters that the Poisson reconstruction applies.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <span>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/handle_transform.h"

namespace hdeform {

/// A rotation and a uniform scale per vertex: the handle's edit spread by the harmonic field.
struct DeformationField {
  Eigen::MatrixXd rotation;  ///< n × 4 unit quaternions, columns (w, x, y, z)
  Eigen::VectorXd scale;     ///< n
};

/// The rotation a fraction h of the way from the identity to the handle's: slerp(1, q, h), i.e.
/// the angle h·θ about the handle's axis — for a twist θ may be several turns and the angle is
/// blended as such, where a slerp would see only θ mod 2π.
inline Eigen::Quaterniond blend_rotation(const HandleTransform& handle, double h) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(h * handle.angle, handle.axis));
}
/// The scale a fraction h of the way from 1 to the handle's.
inline double blend_scale(const HandleTransform& handle, double h) { return 1.0 + h * (handle.scale - 1.0); }

/// §5, one handle: each vertex blends by its field value h.
DeformationField blend_field(const Eigen::VectorXd& h, const HandleTransform& handle);

/// Number of scalar fields interpolated for several handles: q0..q3 and s.
inline constexpr int kInterpolatedComponents = 5;

/// One vertex's interpolated (q0, q1, q2, q3, s): four quaternion components and the scale.
using InterpolatedValue = Eigen::Matrix<double, 1, kInterpolatedComponents>;

/// The rotation of interpolated components (q0..q3 normalised; the identity where they vanish).
Eigen::Quaterniond interpolated_rotation(const InterpolatedValue& value);

/// The Dirichlet value of the §7 fields at a handle's vertices: its quaternion, sign-aligned to
/// the identity's hemisphere (w ≥ 0) that the sinks hold, and its scale.
InterpolatedValue interpolation_value(const HandleTransform& handle);
/// ... and at fixed vertices.
inline InterpolatedValue identity_interpolation_value() { return (InterpolatedValue() << 1.0, 0.0, 0.0, 0.0, 1.0).finished(); }

/// §7, several handles: q0..q3 and s interpolated harmonically from the boundary values above,
/// quaternions normalised after.
DeformationField interpolate_field(const DirichletSystem& system, const VertexPartition& partition,
                                   std::span<const HandleTransform> handles);

/// Per-triangle maps that all turn about one axis a:
///   T_t = α_t I + β_t [a]× + γ_t a aᵀ,  α = s cos φ, β = s sin φ, γ = s (1 − cos φ),
/// a rotation by φ_t scaled by s_t. One handle's field has this form (its axis is fixed), and three
/// numbers per triangle instead of nine make the update's right-hand side cheaper to read.
struct AxialMaps {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> coefficients;  ///< (α, β, γ) per triangle
  std::vector<Eigen::Vector2d> angle_table;   ///< scratch: (cos, sin) at the table's angles

  /// Triangle `triangle`'s map as a 3×3 matrix (the rotation about `axis` and the scale its coefficients give).
  Eigen::Matrix3d matrix(std::size_t triangle) const;
};

/// T_t = s_t R_t at each triangle's barycenter, where a linear field takes the mean of its corners.
/// One handle: from the barycentric field value h_t (in [0, 1]). cos and sin of h_t·θ come from a
/// table over [0, θ] plus a short Taylor step: within a few ulp of `std::cos` and `std::sin`, several
/// times faster. Allocation-free once the table has grown to the largest angle used.
void sample_blend_maps(const Eigen::VectorXd& triangle_h, const HandleTransform& handle, AxialMaps& maps);
/// Several handles: from the interpolated components at the corners (n × 5, row-major: one row
/// per vertex), normalising the mean quaternion.
void sample_interpolated_maps(const Eigen::Matrix<double, Eigen::Dynamic, kInterpolatedComponents, Eigen::RowMajor>& components,
                              const Eigen::MatrixXi& triangles, std::vector<Eigen::Matrix3d>& maps);

/// h at each triangle's barycenter: the mean of its corners.
Eigen::VectorXd barycenter_values(const Eigen::VectorXd& vertex_values, const Eigen::MatrixXi& triangles);
/// The same for several values per vertex (one row each): one row per triangle.
Eigen::MatrixXd barycenter_values(const Eigen::MatrixXd& vertex_values, const Eigen::MatrixXi& triangles);

}  // namespace hdeform

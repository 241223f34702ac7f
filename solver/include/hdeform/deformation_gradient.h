#pragma once
/// @file
/// The deformation of each triangle from a rest shape to a pose (Sumner & Popović 2004, as in
/// design.md): a virtual fourth vertex along the normal, scaled by the square root of the edge
/// cross product's length, makes the triangle a tetrahedron, and
///   v4 = v1 + (v2−v1)×(v3−v1)/sqrt(|(v2−v1)×(v3−v1)|),  V = [v2−v1, v3−v1, v4−v1],  Q = V' V⁻¹.
/// Q maps the rest edges onto the posed edges exactly, and the rest normal onto the posed normal
/// scaled by the square root of the area's growth. So a rotation with a uniform scale gives Q = A
/// exactly; a general affine map A gives a Q that equals A on the triangle's plane (a triangle
/// cannot tell how A moves points off its plane).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "hdeform/mesh.h"

namespace hdeform {

/// Q for one triangle; the identity for a rest triangle of zero area (it has no frame).
Eigen::Matrix3d deformation_gradient(const Eigen::Vector3d& v1, const Eigen::Vector3d& v2, const Eigen::Vector3d& v3,
                                     const Eigen::Vector3d& w1, const Eigen::Vector3d& w2, const Eigen::Vector3d& w3);

/// Q for every triangle of `rest`, with `posed` its vertex positions in the pose (n×3). Parallel;
/// `gradients` is resized to the triangle count and reused.
void deformation_gradients(const Mesh& rest, const Eigen::MatrixXd& posed, std::vector<Eigen::Matrix3d>& gradients);

/// The rotation and the uniform scale of a deformation (polar decomposition Q = R S, the rotation
/// as a unit quaternion with w ≥ 0, s = cbrt(|det Q|)). A reflection (det Q < 0, a flipped
/// triangle) gives the nearest rotation; a collapsed Q gives scale 0.
struct RotationScale {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  double scale = 1.0;
};
/// A deformation split by polar decomposition: its rotation (a unit quaternion) and its uniform scale.
RotationScale rotation_and_scale(const Eigen::Matrix3d& deformation);

}  // namespace hdeform

#pragma once
/// @file
/// The rotation closest to a 3×3 matrix A: R ∈ SO(3) maximising tr(Rᵀ A), i.e. the rotation of
/// A's polar decomposition when det A > 0 (Kabsch/Procrustes; as-rigid-as-possible's local step,
/// where A = Σ w (p'_a − p'_b)(p_a − p_b)ᵀ and R is the rotation that best maps rest edges onto
/// deformed ones).
///
/// Newton's method on SO(3) from a starting rotation matrix (the previous fit, in an iteration that
/// moves little), with the update R ← exp([δ]×) R; each step solves (tr M·I − sym M) δ =
/// axial(M − Mᵀ) for M = A Rᵀ and converges quadratically, so a warm start needs one or two steps
/// where an SVD costs far more. Where that matrix is not positive definite or a long step would
/// lower the objective (far from the answer, a half turn away, at a saddle, A of rank one), the
/// answer comes from Eigen's JacobiSVD. No step lowers tr(Rᵀ A) beyond rounding, so a fit stopped
/// early (`max_steps`) still improves on its start.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <span>

namespace hdeform {

/// A fitted rotation and how it was found (Newton steps, or the SVD where Newton's model failed).
struct RotationFit {
  Eigen::Matrix3d rotation;
  double objective = 0.0;  ///< tr(Rᵀ A)
  int steps = 0;           ///< Newton or gradient steps taken
  bool fell_back_to_svd = false;
};

/// From the rotation `start`; stops after a Newton step of less than `tolerance` radians (what is
/// left is of its square) or after `max_steps` steps.
RotationFit fit_rotation(const Eigen::Matrix3d& a, const Eigen::Matrix3d& start, double tolerance = 1e-7, int max_steps = 16);

/// fit_rotation for many matrices at once, four side by side in SIMD lanes (AVX2 where the CPU has
/// it): `fits[i]` holds the same bits as `fit_rotation(a[i], start[i], tolerance, max_steps)`,
/// whatever the neighbours of i and however the work is split. The three spans have one length
/// (std::invalid_argument otherwise).
void fit_rotations(std::span<const Eigen::Matrix3d> a, std::span<const Eigen::Matrix3d> start, std::span<RotationFit> fits,
                   double tolerance = 1e-7, int max_steps = 16);

/// The same answer by Eigen's JacobiSVD (R = U diag(1, 1, det UVᵀ) Vᵀ): the reference.
Eigen::Matrix3d closest_rotation_svd(const Eigen::Matrix3d& a);

/// The rotation nearest to a matrix that is one up to rounding (a product of many small turns).
Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& nearly_rotation);

}  // namespace hdeform

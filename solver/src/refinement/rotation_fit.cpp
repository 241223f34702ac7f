#include "hdeform/rotation_fit.h"

#include <Eigen/SVD>

#include <cmath>

namespace hdeform {
namespace {

double objective(const Eigen::Matrix3d& rotation, const Eigen::Matrix3d& a) { return (rotation.array() * a.array()).sum(); }

// The turn by 2·atan(|δ|/2) ≈ |δ| about δ (the rotation of the unit quaternion along (1, δ/2)),
// which agrees with exp([δ]×) to second order and so keeps Newton's quadratic convergence
// without a sine or cosine: C = I + 2/(1 + |u|²) ([u]× + [u]×²), u = δ/2.
Eigen::Matrix3d turn(const Eigen::Vector3d& delta) {
  const Eigen::Vector3d u = 0.5 * delta;
  const double s = 2.0 / (1.0 + u.squaredNorm());
  Eigen::Matrix3d cross;
  cross << 0.0, -u.z(), u.y(), u.z(), 0.0, -u.x(), -u.y(), u.x(), 0.0;
  return Eigen::Matrix3d::Identity() + s * (cross + cross * cross);
}

// δ = H⁻¹ v for a symmetric H, or false where H is not positive definite.
bool solve_positive_definite(const Eigen::Matrix3d& h, const Eigen::Vector3d& v, Eigen::Vector3d& delta) {
  const double minor2 = h(0, 0) * h(1, 1) - h(0, 1) * h(0, 1);
  const double c00 = h(1, 1) * h(2, 2) - h(1, 2) * h(1, 2);
  const double c01 = h(0, 2) * h(1, 2) - h(0, 1) * h(2, 2);
  const double c02 = h(0, 1) * h(1, 2) - h(0, 2) * h(1, 1);
  const double determinant = h(0, 0) * c00 + h(0, 1) * c01 + h(0, 2) * c02;
  if (!(h(0, 0) > 0.0 && minor2 > 0.0 && determinant > 0.0)) return false;
  const double c11 = h(0, 0) * h(2, 2) - h(0, 2) * h(0, 2);
  const double c12 = h(0, 1) * h(0, 2) - h(0, 0) * h(1, 2);
  const double c22 = minor2;
  delta = Eigen::Vector3d(c00 * v(0) + c01 * v(1) + c02 * v(2), c01 * v(0) + c11 * v(1) + c12 * v(2), c02 * v(0) + c12 * v(1) + c22 * v(2)) /
          determinant;
  return delta.allFinite();
}

}  // namespace

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
  // Newton steps this short lie where the quadratic model holds: taken whatever the objective's
  // last bits say, so that the fit converges to `tolerance` and not only to the objective's rounding.
  constexpr double kTrustedStep = 1e-2;
  RotationFit fit{start, objective(start, a), 0, false};
  for (; fit.steps < max_steps; ++fit.steps) {
    // f(exp([δ]×) R) ≈ f(R) + v·δ − ½ δᵀ H δ with M = A Rᵀ, v = axial(M − Mᵀ), H = tr M·I − sym M.
    const Eigen::Matrix3d m = a * fit.rotation.transpose();
    const Eigen::Vector3d gradient(m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1));
    const double trace = m.trace();
    Eigen::Matrix3d hessian = -0.5 * (m + m.transpose());
    hessian.diagonal().array() += trace;
    Eigen::Vector3d delta;
    if (!solve_positive_definite(hessian, gradient, delta)) break;
    const double length = delta.norm();
    const Eigen::Matrix3d candidate = turn(delta) * fit.rotation;
    const double value = objective(candidate, a);
    if (value < fit.objective && length >= kTrustedStep) break;
    fit.rotation = candidate;
    fit.objective = value;
    if (length < tolerance) {
      ++fit.steps;
      return fit;
    }
  }
  if (fit.steps == max_steps) return fit;  // improved, not converged: a caller that iterates continues
  // Outside the region where Newton's method holds (far from the answer, a half turn away, at a
  // saddle, or A of rank one): the exact answer instead. Rare in an iteration that moves little.
  const Eigen::Matrix3d exact = closest_rotation_svd(a);
  const double value = objective(exact, a);
  if (value >= fit.objective) {
    fit.rotation = exact;
    fit.objective = value;
    fit.fell_back_to_svd = true;
  }
  return fit;
}

}  // namespace hdeform

#pragma once
// Newton's method for the closest rotation (rotation_fit.h) as inline templates over a lane type,
// private to the solver: rotation_fit.cpp fits the public API's matrices with them, and the
// refinement (arap_refinement.cpp) fits its covariances without copying them out first. Every
// function is inlined into its caller, so that each caller's AVX2 clone (target_clones.h) compiles
// it for AVX2.
#include <Eigen/Core>

#include "hdeform/rotation_fit.h"
#include "../lanes.h"

namespace hdeform::rotation_lanes {

// Newton's iteration is written once, for a lane type T: `double` (one problem) or a vector of
// four doubles (four problems side by side in SIMD lanes, GCC/Clang vector extensions). Every
// lane follows exactly the arithmetic of a single problem: a lane that stops is masked from further
// change, never told what its neighbours did. So a fit is the same bits alone or in any group, on
// any number of threads, and (without FMA, which neither the portable build nor the callers' AVX2
// clones enable) on any x86-64 machine.
using Lanes = detail::Lanes4;
// The lanes' helpers are inlined into their callers, so that a caller's AVX2 clone compiles them
// for AVX2 (a call would run them as compiled for the baseline).
#define HDEFORM_LANE_INLINE [[gnu::always_inline]] inline  // #undef at the end of this header
using LaneMask = detail::LaneBits4;
constexpr int kLanes = 4;

template <class T>
struct LaneTraits {
  using Mask = bool;
  static bool any(bool mask) { return mask; }
  using Count = long;
  static void count(Count& steps, bool taken) { steps += taken ? 1 : 0; }
  static void set_all(Mask& mask) { mask = true; }
};
template <>
struct LaneTraits<Lanes> {
  using Mask = LaneMask;
  // (Vectors pass by reference: by value their ABI would differ between the AVX2 clone and the rest.)
  HDEFORM_LANE_INLINE static bool any(const LaneMask& mask) {
    for (int lane = 0; lane < kLanes; ++lane) {
      if (mask[lane] != 0) return true;
    }
    return false;
  }
  using Count = LaneMask;
  HDEFORM_LANE_INLINE static void count(Count& steps, const LaneMask& taken) { steps -= taken; }  // a set lane is −1
  HDEFORM_LANE_INLINE static void set_all(Mask& mask) { mask = LaneMask{} == 0; }
};

// Row-major 3×3 matrices of lanes.
template <class T>
struct Matrix3 {
  T m[3][3];
};

// tr(Rᵀ A), into `sum`.
template <class T>
HDEFORM_LANE_INLINE void objective_of(const Matrix3<T>& rotation, const Matrix3<T>& a, T& sum) {
  sum = rotation.m[0][0] * a.m[0][0];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (i != 0 || j != 0) sum += rotation.m[i][j] * a.m[i][j];
    }
  }
}

// What the iteration leaves in each lane.
template <class T>
struct LaneFit {
  Matrix3<T> rotation;
  T objective;
  typename LaneTraits<T>::Count steps;
  typename LaneTraits<T>::Mask needs_svd;
};

// Newton's method on SO(3) (see the header) from `start`, in every lane at once.
template <class T>
HDEFORM_LANE_INLINE LaneFit<T> newton(const Matrix3<T>& a, const Matrix3<T>& start, double tolerance, int max_steps) {
  using Traits = LaneTraits<T>;
  using Mask = typename Traits::Mask;
  // Newton steps this short lie where the quadratic model holds: taken whatever the objective's
  // last bits say, so that the fit converges to `tolerance` and not only to the objective's rounding.
  constexpr double kTrustedStep = 1e-2;
  const double trusted_squared = kTrustedStep * kTrustedStep;
  const double tolerance_squared = tolerance * tolerance;
  // Member by member: an aggregate's initializer made GCC clear the whole result with a `rep stos`
  // first, a sixth of the fits' time.
  LaneFit<T> fit;
  fit.rotation = start;
  fit.steps = typename Traits::Count{};
  fit.needs_svd = Mask{};
  objective_of(start, a, fit.objective);
  Mask active;
  Traits::set_all(active);
  for (int step = 0; step < max_steps && Traits::any(active); ++step) {
    // f(exp([δ]×) R) ≈ f(R) + v·δ − ½ δᵀ H δ with M = A Rᵀ, v = axial(M − Mᵀ), H = tr M·I − sym M.
    const auto& r = fit.rotation.m;
    T m[3][3];
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m[i][j] = a.m[i][0] * r[j][0] + a.m[i][1] * r[j][1] + a.m[i][2] * r[j][2];
    }
    const T v0 = m[2][1] - m[1][2], v1 = m[0][2] - m[2][0], v2 = m[1][0] - m[0][1];
    const T trace = m[0][0] + m[1][1] + m[2][2];
    const T h00 = trace - m[0][0], h11 = trace - m[1][1], h22 = trace - m[2][2];
    const T h01 = -0.5 * (m[0][1] + m[1][0]), h02 = -0.5 * (m[0][2] + m[2][0]), h12 = -0.5 * (m[1][2] + m[2][1]);
    // δ = H⁻¹ v by cofactors, where H is positive definite (leading minors positive).
    const T minor2 = h00 * h11 - h01 * h01;
    const T c00 = h11 * h22 - h12 * h12, c01 = h02 * h12 - h01 * h22, c02 = h01 * h12 - h02 * h11;
    const T determinant = h00 * c00 + h01 * c01 + h02 * c02;
    const T c11 = h00 * h22 - h02 * h02, c12 = h01 * h02 - h00 * h12, c22 = minor2;
    const T d0 = (c00 * v0 + c01 * v1 + c02 * v2) / determinant;
    const T d1 = (c01 * v0 + c11 * v1 + c12 * v2) / determinant;
    const T d2 = (c02 * v0 + c12 * v1 + c22 * v2) / determinant;
    // (x − x == 0 is false exactly for infinities and NaN.)
    const Mask model_holds = (h00 > 0.0) & (minor2 > 0.0) & (determinant > 0.0) & (d0 - d0 == 0.0) & (d1 - d1 == 0.0) & (d2 - d2 == 0.0);
    const T length_squared = d0 * d0 + d1 * d1 + d2 * d2;
    // The turn by 2·atan(|δ|/2) ≈ |δ| about δ (the rotation of the unit quaternion along (1, δ/2)),
    // which agrees with exp([δ]×) to second order and so keeps Newton's quadratic convergence
    // without a sine or cosine: C = I + s ([u]× + [u]×²), u = δ/2, s = 2/(1 + |u|²).
    const T u0 = 0.5 * d0, u1 = 0.5 * d1, u2 = 0.5 * d2;
    const T s = 2.0 / (1.0 + (u0 * u0 + u1 * u1 + u2 * u2));
    const T turn[3][3] = {{1.0 - s * (u1 * u1 + u2 * u2), s * (u0 * u1 - u2), s * (u0 * u2 + u1)},
                          {s * (u0 * u1 + u2), 1.0 - s * (u0 * u0 + u2 * u2), s * (u1 * u2 - u0)},
                          {s * (u0 * u2 - u1), s * (u1 * u2 + u0), 1.0 - s * (u0 * u0 + u1 * u1)}};
    Matrix3<T> candidate;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) candidate.m[i][j] = turn[i][0] * r[0][j] + turn[i][1] * r[1][j] + turn[i][2] * r[2][j];
    }
    T value;
    objective_of(candidate, a, value);
    // A long step that lowers the objective: Newton's model does not hold here.
    const Mask lowers = (value < fit.objective) & (length_squared >= trusted_squared);
    const Mask taken = active & model_holds & !lowers;
    fit.needs_svd = fit.needs_svd | (active & !taken);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) fit.rotation.m[i][j] = taken ? candidate.m[i][j] : fit.rotation.m[i][j];
    }
    fit.objective = taken ? value : fit.objective;
    Traits::count(fit.steps, taken);
    active = taken & !(length_squared < tolerance_squared);
  }
  return fit;
}

inline Matrix3<double> from_eigen(const Eigen::Matrix3d& matrix) {
  Matrix3<double> out;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.m[i][j] = matrix(i, j);
  }
  return out;
}

inline Eigen::Matrix3d to_eigen(const Matrix3<double>& matrix) {
  Eigen::Matrix3d out;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out(i, j) = matrix.m[i][j];
  }
  return out;
}

// Outside the region where Newton's method holds (far from the answer, a half turn away, at a
// saddle, or A of rank one): the exact answer instead, if it is better. Rare in an iteration that
// moves little.
inline void finish_with_svd(const Eigen::Matrix3d& a, RotationFit& fit) {
  const Eigen::Matrix3d exact = closest_rotation_svd(a);
  double value;
  objective_of(from_eigen(exact), from_eigen(a), value);
  if (value >= fit.objective) {
    fit.rotation = exact;
    fit.objective = value;
    fit.fell_back_to_svd = true;
  }
}

}  // namespace hdeform::rotation_lanes

#undef HDEFORM_LANE_INLINE

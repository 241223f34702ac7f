#pragma once
// L stored in single precision, and the iterative refinement that gives its solves back double
// accuracy (private to the linear algebra).
//
// Stored in single precision, L's values take half their bytes (the row indices of the forward
// sweep stay 4 bytes each): 436 MB less at 3.3M triangles solved exactly. A solve does not get
// faster for it on the machines measured (README, Performance): the sweeps wait on their gathers
// more than on L's bytes. The rounding costs about 1e-7 of relative accuracy, which refinement
// recovers: with X₀ the single-precision solution, each step computes the residual R = B − A X in
// double against A itself and adds the single-precision solution of A D = R. Each step shrinks
// the error by a factor ρ ≈ κ·2⁻²⁴, so a matrix with ρ too close to 1 (too ill-conditioned for
// single precision) is refused at set-up.
//
// The steps stop by a residual test, the one LAPACK's refinement uses: the componentwise backward
// error ω = maxᵢ |R|ᵢ / (|A| |X| + |B|)ᵢ (Oettli–Prager: X is the exact solution of a system whose
// every entry is within a relative ω of A's and B's). A solve is done when ω is at most
// kRefinementTolerance in every column, or when a step no longer halves ω (then double arithmetic
// itself is the limit).
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tree_factorization.h"
#include "uninitialized_vector.h"

namespace hdeform::detail {

// A solve is done when ω is at most this, about 900 units of double rounding. At 1e-12 (one step
// where this takes two) the Buddha's update matched the double one, but five refinement
// iterations, which feed each solution into the next rotation fit, carried the difference to
// 1.8e-10 of the diagonal; at 1e-13 to 1.8e-12.
inline constexpr double kRefinementTolerance = 1e-13;
// A step that does not shrink ω at least this much has reached what a residual computed in
// double can tell: the steps stop there.
inline constexpr double kRefinementStall = 0.5;
// The most correction steps of one solve (each costs a solve and a product with A).
inline constexpr int kMostCorrections = 8;
// Single precision is refused when one correction step shrinks a known solution's error by less
// than this factor: the solves would need many steps, or never reach double accuracy.
inline constexpr double kLargestContraction = 0.01;

// What the refined solves have done so far.
struct RefinementCounts {
  std::int64_t solves = 0;       // refined solves
  std::int64_t corrections = 0;  // correction steps over all of them
  int most_corrections = 0;      // the most steps one solve took
  std::int64_t stalled = 0;      // solves stopped because a step no longer halved ω
};

class SingleFactor {
 public:
  // L in single precision in both layouts, and A (P A Pᵀ) for the residuals.
  SingleFactor(const FactorPattern& pattern, UninitializedVector<float> row_value, UninitializedVector<float> column_value,
               PermutedMatrix matrix);
  // L's double values rounded to single precision.
  static UninitializedVector<float> rounded(std::span<const double> values);

  // Measures the contraction of one step on a known solution. Returns the reason single
  // precision does not serve this matrix, or nullopt when it does.
  std::optional<std::string> calibrate(const FactorPattern& pattern);

  // Solves A X = B in place for a row-major block in factor order, refined to double accuracy.
  // Safe to call concurrently; allocation-free once as many workspaces as concurrent calls exist.
  void solve(const FactorPattern& pattern, double* block, int columns, int stride) const;

  const PermutedMatrix& matrix() const { return matrix_; }
  double contraction() const { return contraction_; }    // error shrink of one step, measured
  RefinementCounts counts() const;

 private:
  struct Workspace {
    std::vector<double> rhs;       // B, compact (columns per row)
    std::vector<double> residual;  // R, then the correction D
    std::vector<double> largest;   // per chunk of rows and column: the largest ω
  };
  std::unique_ptr<Workspace> acquire(std::size_t values, int columns) const;
  void release(std::unique_ptr<Workspace> workspace) const;
  void single_solve(const FactorPattern& pattern, double* block, int columns, int stride) const;
  // One refined solve; returns the correction steps it took and whether it stalled.
  std::pair<int, bool> refine(const FactorPattern& pattern, double* block, int columns, int stride, Workspace& workspace) const;

  UninitializedVector<float> row_value_;
  UninitializedVector<float> column_value_;
  PermutedMatrix matrix_;
  double contraction_ = 0.0;

  mutable std::mutex pool_mutex_;
  mutable std::vector<std::unique_ptr<Workspace>> pool_;
  mutable std::atomic<std::int64_t> solves_{0};
  mutable std::atomic<std::int64_t> corrections_{0};
  mutable std::atomic<int> most_corrections_{0};
  mutable std::atomic<std::int64_t> stalled_{0};
};

}  // namespace hdeform::detail

#include "single_precision_factor.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "hdeform/trace.h"
#include "triangular_sweeps.h"

namespace hdeform::detail {
namespace {

// Rows per task of the element-wise passes (copies, residuals); each chunk also keeps its own
// column maxima, so the passes allocate nothing and the maxima do not depend on the schedule.
constexpr std::size_t kRowsPerChunk = 4096;
// Columns whose sums a residual pass keeps in registers: as many as one sweep kernel takes.
constexpr auto kColumnsPerPass = static_cast<std::size_t>(kMaxKernelColumns);

std::size_t chunk_count(std::size_t rows) { return (rows + kRowsPerChunk - 1) / kRowsPerChunk; }

template <class Body>
void for_each_chunk(std::size_t rows, Body&& body) {
  tbb::parallel_for(std::size_t{0}, chunk_count(rows), [&](std::size_t chunk) {
    const std::size_t first = chunk * kRowsPerChunk;
    body(chunk, first, std::min(rows, first + kRowsPerChunk));
  });
}

// (A x)_k for row k of P A Pᵀ (its column k, A being symmetric), `columns` interleaved vectors
// `stride` apart, into product[0..columns).
void multiply_row(const PermutedMatrix& matrix, std::size_t k, const double* x, int columns, int stride, double* product) {
  for (int c = 0; c < columns; ++c) product[c] = 0.0;
  for (int p = matrix.start[k]; p < matrix.start[k + 1]; ++p) {
    const double a = matrix.value[static_cast<std::size_t>(p)];
    const double* xi = x + static_cast<std::ptrdiff_t>(matrix.row[static_cast<std::size_t>(p)]) * stride;
    for (int c = 0; c < columns; ++c) product[c] += a * xi[c];
  }
}

// largest = max(largest, value), where a NaN, once in, stays: a solve that produced one must not
// pass the residual test on the strength of a later, finite row.
void keep_largest(double& largest, double value) {
  if (!std::isnan(largest) && !(value <= largest)) largest = value;
}

// A fixed pseudo-random value in [−1, 1] for index k (the probe's known solution).
double probe_value(std::size_t k) {
  std::uint64_t z = (static_cast<std::uint64_t>(k) + 1) * 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-52 - 1.0;
}

}  // namespace

UninitializedVector<float> SingleFactor::rounded(std::span<const double> values) {
  UninitializedVector<float> single(values.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, values.size(), 1 << 16), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) single[i] = static_cast<float>(values[i]);
  });
  return single;
}

SingleFactor::SingleFactor(const FactorPattern& pattern, UninitializedVector<float> row_value, UninitializedVector<float> column_value,
                           PermutedMatrix matrix)
    : row_value_(std::move(row_value)), column_value_(std::move(column_value)), matrix_(std::move(matrix)) {
  if (row_value_.size() != pattern.nonzeros() || column_value_.size() != pattern.nonzeros()) {
    throw std::logic_error("SingleFactor: the values are not of this pattern");
  }
}

void SingleFactor::single_solve(const FactorPattern& pattern, double* block, int columns, int stride) const {
  solve_with_factor<float>(pattern, row_value_.data(), column_value_.data(), block, columns, stride);
}

std::optional<std::string> SingleFactor::calibrate(const FactorPattern& pattern) {
  const trace::Scope traced("single precision: probe", "set-up");
  const auto n = static_cast<std::size_t>(pattern.size());
  if (n == 0) return std::nullopt;
  std::vector<double> x(n), y(n);
  auto multiply = [&](const std::vector<double>& from, std::vector<double>& into) {
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) { multiply_row(matrix_, k, from.data(), 1, 1, &into[k]); });
  };

  // The probe: A v for a known v, solved once and corrected once.
  std::vector<double> known(n), rhs(n);
  for (std::size_t k = 0; k < n; ++k) known[k] = probe_value(k);
  multiply(known, rhs);
  x = rhs;
  single_solve(pattern, x.data(), 1, 1);
  auto error = [&] {
    double largest = 0.0;
    for (std::size_t k = 0; k < n; ++k) largest = std::max(largest, std::abs(x[k] - known[k]));
    return largest;
  };
  const double first_error = error();
  multiply(x, y);
  for (std::size_t k = 0; k < n; ++k) y[k] = rhs[k] - y[k];
  single_solve(pattern, y.data(), 1, 1);
  for (std::size_t k = 0; k < n; ++k) x[k] += y[k];
  const double corrected_error = error();
  contraction_ = first_error > 0.0 ? corrected_error / first_error : 0.0;
  if (!std::isfinite(contraction_) || contraction_ > kLargestContraction) {
    char reason[256];
    std::snprintf(reason, sizeof reason,
                  "the matrix is too ill-conditioned for a single-precision factor (a correction step shrinks the error only "
                  "%.3g times; at least %.0f needed), so the solves use the double factor",
                  contraction_ > 0.0 ? 1.0 / contraction_ : 0.0, 1.0 / kLargestContraction);
    return std::string(reason);
  }
  return std::nullopt;
}

std::unique_ptr<SingleFactor::Workspace> SingleFactor::acquire(std::size_t values, int columns) const {
  std::unique_ptr<Workspace> workspace;
  {
    const std::lock_guard lock(pool_mutex_);
    if (!pool_.empty()) {
      workspace = std::move(pool_.back());
      pool_.pop_back();
    }
  }
  if (!workspace) workspace = std::make_unique<Workspace>();
  // resize() keeps the capacity of earlier, larger solves: no allocation in steady state.
  workspace->rhs.resize(values);
  workspace->residual.resize(values);
  workspace->largest.resize(chunk_count(values / static_cast<std::size_t>(columns)) * static_cast<std::size_t>(columns));
  return workspace;
}

void SingleFactor::release(std::unique_ptr<Workspace> workspace) const {
  const std::lock_guard lock(pool_mutex_);
  pool_.push_back(std::move(workspace));
}

std::pair<int, bool> SingleFactor::refine(const FactorPattern& pattern, double* block, int columns, int stride, Workspace& workspace) const {
  const auto rows = static_cast<std::size_t>(pattern.size());
  const auto width = static_cast<std::size_t>(columns);
  const std::size_t chunks = chunk_count(rows);
  double* rhs = workspace.rhs.data();
  double* residual = workspace.residual.data();
  // Per chunk and column: the largest backward error of the chunk's rows, at [chunk·columns + c].
  double* largest = workspace.largest.data();
  for_each_chunk(rows, [&](std::size_t, std::size_t first, std::size_t last) {
    for (std::size_t k = first; k < last; ++k) std::copy_n(block + k * static_cast<std::size_t>(stride), width, rhs + k * width);
  });
  single_solve(pattern, block, columns, stride);

  // The largest componentwise backward error ω over rows and columns (see the header); leaves R
  // in `residual`.
  auto backward_error = [&] {
    for_each_chunk(rows, [&](std::size_t chunk, std::size_t first, std::size_t last) {
      double* chunk_largest = largest + chunk * width;
      std::fill_n(chunk_largest, width, 0.0);
      for (std::size_t k = first; k < last; ++k) {
        // A handful of columns at a time, so that the sums stay in registers.
        for (std::size_t group = 0; group < width; group += kColumnsPerPass) {
          const std::size_t count = std::min(kColumnsPerPass, width - group);
          double* r = residual + k * width + group;
          const double* b = rhs + k * width + group;
          double scale[kColumnsPerPass];
          for (std::size_t c = 0; c < count; ++c) {
            r[c] = b[c];
            scale[c] = std::abs(b[c]);
          }
          for (int p = matrix_.start[k]; p < matrix_.start[k + 1]; ++p) {
            const double a = matrix_.value[static_cast<std::size_t>(p)];
            const double* x = block + static_cast<std::ptrdiff_t>(matrix_.row[static_cast<std::size_t>(p)]) * stride + group;
            for (std::size_t c = 0; c < count; ++c) {
              r[c] -= a * x[c];
              scale[c] += std::abs(a * x[c]);
            }
          }
          for (std::size_t c = 0; c < count; ++c) {
            // A row whose |A||X| + |B| is 0 has a zero residual too, unless something is not finite.
            const double omega = scale[c] > 0.0 ? std::abs(r[c]) / scale[c] : std::abs(r[c]);
            keep_largest(chunk_largest[group + c], omega);
          }
        }
      }
    });
    double worst = 0.0;
    for (std::size_t i = 0; i < chunks * width; ++i) keep_largest(worst, largest[i]);
    return worst;
  };

  int steps = 0;
  double previous = std::numeric_limits<double>::infinity();
  for (;;) {
    const double worst = backward_error();
    if (worst <= kRefinementTolerance) return {steps, false};
    // Not shrinking (or not a number): what a double residual can tell has been reached.
    if (steps == kMostCorrections || !(worst <= kRefinementStall * previous)) return {steps, true};
    previous = worst;
    {
      const trace::Scope traced("correction step", "solve", steps);
      single_solve(pattern, residual, columns, columns);
    }
    for_each_chunk(rows, [&](std::size_t, std::size_t first, std::size_t last) {
      for (std::size_t k = first; k < last; ++k) {
        double* x = block + k * static_cast<std::size_t>(stride);
        const double* d = residual + k * width;
        for (std::size_t c = 0; c < width; ++c) x[c] += d[c];
      }
    });
    ++steps;
  }
}

void SingleFactor::solve(const FactorPattern& pattern, double* block, int columns, int stride) const {
  if (pattern.size() == 0 || columns <= 0) return;
  auto workspace = acquire(static_cast<std::size_t>(pattern.size()) * static_cast<std::size_t>(columns), columns);
  const auto [steps, stalled] = refine(pattern, block, columns, stride, *workspace);
  release(std::move(workspace));
  solves_.fetch_add(1, std::memory_order_relaxed);
  corrections_.fetch_add(steps, std::memory_order_relaxed);
  if (stalled) stalled_.fetch_add(1, std::memory_order_relaxed);
  int most = most_corrections_.load(std::memory_order_relaxed);
  while (steps > most && !most_corrections_.compare_exchange_weak(most, steps, std::memory_order_relaxed)) {
  }
}

RefinementCounts SingleFactor::counts() const {
  return {solves_.load(), corrections_.load(), most_corrections_.load(), stalled_.load()};
}

}  // namespace hdeform::detail

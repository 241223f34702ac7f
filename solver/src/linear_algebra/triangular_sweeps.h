#pragma once
// The forward and backward sweeps of a solve with L Lᵀ (private to the linear algebra), for L
// stored in double or in single precision. The right-hand sides and every sum stay in double
// whatever L is stored in: a single-precision L costs only the rounding of its own entries.
//
// Both sweeps are gathers, so each unknown is summed in one fixed order, and disjoint subtrees of
// the elimination tree run concurrently with the same bits on any number of threads.
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <span>
#include <type_traits>

#include "hdeform/sparse_cholesky.h"
#include "hdeform/trace.h"
#include "../lanes.h"
#include "../target_clones.h"
#include "tree_factorization.h"

namespace hdeform::detail {

// Both sweeps sum each unknown's products with four independent partial sums: a single running
// sum would chain every product through the adder's latency, and two chains still held the sweeps
// at the adder. The order is fixed (below) and the same for any number of columns, so a column's
// result depends neither on threads, nor on the stride, nor on the columns solved beside it.
inline constexpr int kPartialSums = 4;

// Calls add(s, i) for i in [0, count), each entry into partial sum s: entry i into i mod 4, then a
// last pair into the first two and a last single entry into the first. The caller then totals
// (p0 + p2) + (p1 + p3). One order for every gather, so that all of them give the same bits.
// add_four(i) stands for add(0, i) … add(3, i + 3), for a gather that loads four entries at once.
template <class AddFour, class Add>
[[gnu::always_inline]] inline void in_summation_order(int count, AddFour&& add_four, Add&& add) {
  int i = 0;
  for (; i + 4 <= count; i += 4) add_four(i);
  if (i + 2 <= count) {
    add(0, i);
    add(1, i + 1);
    i += 2;
  }
  if (i < count) add(0, i);
}
template <class Add>
[[gnu::always_inline]] inline void in_summation_order(int count, Add&& add) {
  in_summation_order(
      count,
      [&](int i) __attribute__((always_inline)) {
        add(0, i);
        add(1, i + 1);
        add(2, i + 2);
        add(3, i + 3);
      },
      add);
}

// Σ value[i]·y[index[i]] for i in [0, count), K interleaved columns `stride` apart, into
// sum[0..K): a gather along a row's columns or a column's rows.
// (The gathers are always inlined: each then takes the instruction set of the sweep it is in.)
template <int K, class T>
[[gnu::always_inline]] inline void gather(const int* index, const T* value, int count, const double* y, int stride, double* sum) {
  double partial[kPartialSums][K] = {};
  in_summation_order(count, [&](int s, int i) __attribute__((always_inline)) {
    const double l = value[i];
    const double* yi = y + static_cast<std::ptrdiff_t>(index[i]) * stride;
    for (int k = 0; k < K; ++k) partial[s][k] += l * yi[k];
  });
  for (int k = 0; k < K; ++k) sum[k] = (partial[0][k] + partial[2][k]) + (partial[1][k] + partial[3][k]);
}

// Four consecutive values of L as doubles (a float's conversion is exact).
template <class T>
[[gnu::always_inline]] inline void load_four_values(const T* value, Lanes4& lanes) {
  if constexpr (std::is_same_v<T, double>) {
    load_lanes(value, lanes);
  } else {
    using Float4 = float __attribute__((vector_size(16)));
    Float4 values;
    std::memcpy(&values, value, sizeof values);
    lanes = __builtin_convertvector(values, Lanes4);
  }
}

// The same sums four lanes at a time: one load of four consecutive values of a row per entry where
// the plain gather makes one per column, V loads for up to 4·V columns. The lanes beyond the K
// columns are read and never written (a pad, or columns nobody writes meanwhile). Each lane's
// products and sums are the plain gather's, in its order. Four entries at a time, their values and
// indices come in one load each and are spread in registers: the sweeps are bound by their loads
// (three per entry otherwise). On the Buddha this took a seventh off the top's forward sweep with a
// warm cache, and a twentieth off a subtree's.
template <int K, int V, class T>
[[gnu::always_inline]] inline void gather_lanes(const int* index, const T* value, int count, const double* y, int stride, double* sum) {
  static_assert(V == 1 || V == 2);
  static_assert(K <= 4 * V);
  // The partial sums of a row's first and second four values in two arrays, not one: GCC keeps an
  // array of four vectors in registers, while one of eight lived on the stack, cleared for every
  // row, and took five to eight columns twice as long as four.
  Lanes4 first[kPartialSums] = {}, second[kPartialSums] = {};
  auto add = [&](int s, const Lanes4& l, int at) __attribute__((always_inline)) {
    const double* yi = y + static_cast<std::ptrdiff_t>(at) * stride;
    Lanes4 lanes;
    load_lanes(yi, lanes);
    first[s] += l * lanes;
    if constexpr (V == 2) {
      load_lanes(yi + 4, lanes);
      second[s] += l * lanes;
    }
  };
  using Index4 = int __attribute__((vector_size(16)));
  in_summation_order(
      count,
      [&](int i) __attribute__((always_inline)) {
        Lanes4 l;
        load_four_values(value + i, l);
        Index4 at;
        std::memcpy(&at, index + i, sizeof at);
        add(0, __builtin_shufflevector(l, l, 0, 0, 0, 0), at[0]);
        add(1, __builtin_shufflevector(l, l, 1, 1, 1, 1), at[1]);
        add(2, __builtin_shufflevector(l, l, 2, 2, 2, 2), at[2]);
        add(3, __builtin_shufflevector(l, l, 3, 3, 3, 3), at[3]);
      },
      [&](int s, int i) __attribute__((always_inline)) { add(s, Lanes4{} + static_cast<double>(value[i]), index[i]); });
  const Lanes4 total = (first[0] + first[2]) + (first[1] + first[3]);
  for (int k = 0; k < std::min(K, 4); ++k) sum[k] = total[k];
  if constexpr (V == 2) {
    const Lanes4 rest = (second[0] + second[2]) + (second[1] + second[3]);
    for (int k = 4; k < K; ++k) sum[k] = rest[k - 4];
  }
}

// V = 0: the plain gather; V > 0: the lanes.
template <int K, int V, class T>
[[gnu::always_inline]] inline void gather_products(const int* index, const T* value, int count, const double* y, int stride, double* sum) {
  if constexpr (V == 0) gather<K>(index, value, count, y, stride, sum);
  else gather_lanes<K, V>(index, value, count, y, stride, sum);
}

// Forward sweep L y = b over `columns` (ascending), K interleaved right-hand sides: a gather
// along row j of L, the diagonal last. Compiled for AVX2 and for the baseline (where each
// four-lane operation is two SSE2 ones); AVX2 alone brings no FMA, so both give the same bits.
// V: the gather's vectors per row (0: the plain gather).
template <int K, int V, class T>
HDEFORM_TARGET_CLONES("avx2", "default")
void forward_sweep(const FactorPattern& pattern, const T* value, std::span<const int> columns, double* y, int stride) {
  for (const int j : columns) {
    const auto row = static_cast<std::size_t>(j);
    const int first = pattern.row_start[row];
    const int diagonal = pattern.row_start[row + 1] - 1;
    double products[K];
    gather_products<K, V>(pattern.row_column.data() + first, value + first, diagonal - first, y, stride, products);
    double* yj = y + static_cast<std::ptrdiff_t>(j) * stride;
    const double inverse_diagonal = 1.0 / static_cast<double>(value[diagonal]);
    for (int k = 0; k < K; ++k) yj[k] = (yj[k] - products[k]) * inverse_diagonal;
  }
}

// Backward sweep Lᵀ x = y over `columns` (descending): a gather along column j of L (diagonal
// first), with L's columns stored last to first and each column's rows the end of its
// supernode's row list.
template <int K, int V, class T>
HDEFORM_TARGET_CLONES("avx2", "default")
void backward_sweep(const FactorPattern& pattern, const T* value, std::span<const int> columns, double* y, int stride) {
  for (auto it = columns.rbegin(); it != columns.rend(); ++it) {
    const int j = *it;
    const T* l = value + pattern.column_begin[static_cast<std::size_t>(j)];
    const auto length = static_cast<int>(pattern.column_length(j));
    double products[K];
    gather_products<K, V>(pattern.column_rows(j) + 1, l + 1, length - 1, y, stride, products);
    double* yj = y + static_cast<std::ptrdiff_t>(j) * stride;
    const double inverse_diagonal = 1.0 / static_cast<double>(l[0]);
    for (int k = 0; k < K; ++k) yj[k] = (yj[k] - products[k]) * inverse_diagonal;
  }
}

inline constexpr int kMaxKernelColumns = 8;

template <class T>
struct Sweeps {
  void (*forward)(const FactorPattern&, const T*, std::span<const int>, double*, int);
  void (*backward)(const FactorPattern&, const T*, std::span<const int>, double*, int);
};
template <int K, int V, class T>
constexpr Sweeps<T> sweeps_for() {
  return {forward_sweep<K, V, T>, backward_sweep<K, V, T>};
}
// By the number of columns: the plain gather (1 to 8 columns), and the lanes (3 to 8 columns: one
// vector per row for three or four, two for five to eight).
template <class T>
inline constexpr Sweeps<T> kSweeps[kMaxKernelColumns] = {sweeps_for<1, 0, T>(), sweeps_for<2, 0, T>(), sweeps_for<3, 0, T>(), sweeps_for<4, 0, T>(),
                                                         sweeps_for<5, 0, T>(), sweeps_for<6, 0, T>(), sweeps_for<7, 0, T>(), sweeps_for<8, 0, T>()};
inline constexpr int kFewestLaneColumns = 3;
template <class T>
inline constexpr Sweeps<T> kLaneSweeps[kMaxKernelColumns - kFewestLaneColumns + 1] = {
    sweeps_for<3, 1, T>(), sweeps_for<4, 1, T>(), sweeps_for<5, 2, T>(), sweeps_for<6, 2, T>(), sweeps_for<7, 2, T>(), sweeps_for<8, 2, T>()};

enum class Direction { Forward, Backward };

// Sweeps the top of the tree chain by chain: forward, a chain after the chains below it; backward,
// before them. Sibling chains run concurrently (when `concurrent`) while their share of the top's
// work is large enough to pay for a task.
template <class Sweep>
void sweep_top(const TopChains& chains, bool concurrent, Direction direction, const Sweep& sweep) {
  double total = 0.0;
  for (const int root : chains.roots) total += chains.work[static_cast<std::size_t>(root)];
  const double task_work = total / 64.0;
  auto each = [&](std::span<const int> list, auto&& visit) {
    const bool split = concurrent && list.size() > 1 &&
                       std::count_if(list.begin(), list.end(), [&](int c) { return chains.work[static_cast<std::size_t>(c)] >= task_work; }) > 1;
    if (split) tbb::parallel_for(std::size_t{0}, list.size(), [&](std::size_t i) { visit(list[i]); }, tbb::simple_partitioner());
    else for (const int c : list) visit(c);
  };
  auto visit = [&](auto&& self, int chain) -> void {
    if (direction == Direction::Backward) sweep(chains.nodes_of(chain));
    each(chains.children_of(chain), [&](int child) { self(self, child); });
    if (direction == Direction::Forward) sweep(chains.nodes_of(chain));
  };
  each(chains.roots, [&](int root) { visit(visit, root); });
}

// Solves L Lᵀ X = B in place for a row-major block in factor order (`columns` values per row,
// rows `stride` apart), with L's values by rows (forward) and by stored columns (backward).
template <class T>
void solve_with_factor(const FactorPattern& pattern, const T* row_value, const T* column_value, double* block, int columns, int stride) {
  const auto& subtrees = pattern.schedule.subtrees;
  // One kernel's columns at a time: the subtrees' sweeps side by side (as in a drag's three or
  // five columns), or, with `side_by_side` false, one after the other on this thread.
  auto solve_columns = [&](int first, bool side_by_side) {
    const int width = std::min(kMaxKernelColumns, columns - first);
    // Lanes read four or eight values of a row from the kernel's first column: its own columns,
    // and for the last kernel, whose width may be less, the block's pad after the last column,
    // which nobody writes (so kernels side by side never read what another writes).
    const int lane_span = width <= 4 ? 4 : 8;
    const bool lanes = width >= kFewestLaneColumns && first + lane_span <= stride;
    const Sweeps<T>& sweeps = lanes ? kLaneSweeps<T>[width - kFewestLaneColumns] : kSweeps<T>[width - 1];
    double* y = block + first;
    // Each sweep of each part is an event of the trace, on the thread that ran it.
    auto each_subtree = [&](const char* name, auto&& sweep) {
      if (subtrees.empty()) return;
      auto one = [&](std::size_t part) {
        const trace::Scope traced(name, "solve", static_cast<std::int64_t>(part));
        sweep(subtrees[part]);
      };
      if (side_by_side) tbb::parallel_for(std::size_t{0}, subtrees.size(), one, tbb::static_partitioner());
      else for (std::size_t part = 0; part < subtrees.size(); ++part) one(part);
    };
    auto forward = [&](std::span<const int> part) { sweeps.forward(pattern, row_value, part, y, stride); };
    auto backward = [&](std::span<const int> part) { sweeps.backward(pattern, column_value, part, y, stride); };
    each_subtree("forward sweep, subtree", forward);
    {
      const trace::Scope traced("forward sweep, top", "solve");
      sweep_top(pattern.schedule.top_chains, side_by_side, Direction::Forward, forward);
    }
    {
      const trace::Scope traced("backward sweep, top", "solve");
      sweep_top(pattern.schedule.top_chains, side_by_side, Direction::Backward, backward);
    }
    each_subtree("backward sweep, subtree", backward);
  };
  const int kernels = (columns + kMaxKernelColumns - 1) / kMaxKernelColumns;
  const int threads = tbb::this_task_arena::max_concurrency();
  if (threads > 1 && kernels >= 2 * threads) {
    // Many columns (harmonic coordinates: one per marker): whole solves side by side, the top
    // included, each thread a contiguous run of kernels so that two threads write the same
    // cache lines only where their runs meet. Every column's arithmetic is the same either way.
    tbb::parallel_for(tbb::blocked_range<int>(0, kernels), [&](const tbb::blocked_range<int>& range) {
      for (int kernel = range.begin(); kernel != range.end(); ++kernel) solve_columns(kernel * kMaxKernelColumns, false);
    }, tbb::static_partitioner());
    return;
  }
  for (int first = 0; first < columns; first += kMaxKernelColumns) solve_columns(first, true);
}

}  // namespace hdeform::detail

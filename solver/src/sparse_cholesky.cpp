#include "hdeform/sparse_cholesky.h"

#include <Eigen/SparseCholesky>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <numeric>
#include <span>
#include <string>

#include "hdeform/errors.h"
#include "hdeform/trace.h"

#ifdef HDEFORM_WITH_CHOLMOD
#include <Eigen/CholmodSupport>
#endif

namespace hdeform {
namespace {

// Forward sweep L y = b over `columns` (ascending), K interleaved right-hand sides: a gather
// along row j of L, read as column j of Lᵀ (diagonal last).
// Independent partial sums per column: a single running sum would chain every product through
// the adder's latency. The split is fixed, so the result does not depend on threads.
template <int K>
constexpr int kPartialSums = 2;

// Σ_p value[p]·y[inner[p]] for p in [begin, end), K interleaved columns, into sum[0..K).
template <int K>
inline void gather_products(const int* inner, const double* value, int begin, int end, const double* y, int stride, double* sum) {
  constexpr int S = kPartialSums<K>;
  double partial[S][K] = {};
  int p = begin;
  for (; p + S <= end; p += S) {
    for (int s = 0; s < S; ++s) {
      const double l = value[p + s];
      const double* yi = y + static_cast<std::ptrdiff_t>(inner[p + s]) * stride;
      for (int k = 0; k < K; ++k) partial[s][k] += l * yi[k];
    }
  }
  for (; p < end; ++p) {
    const double l = value[p];
    const double* yi = y + static_cast<std::ptrdiff_t>(inner[p]) * stride;
    for (int k = 0; k < K; ++k) partial[0][k] += l * yi[k];
  }
  for (int k = 0; k < K; ++k) {
    double total = 0.0;
    for (int s = 0; s < S; ++s) total += partial[s][k];
    sum[k] = total;
  }
}

// Forward sweep L y = b over `columns` (ascending), K interleaved right-hand sides: a gather
// along row j of L, read as column j of Lᵀ (diagonal last).
template <int K>
void forward_sweep(const Eigen::SparseMatrix<double>& upper, std::span<const int> columns, double* y, int stride) {
  const int* outer = upper.outerIndexPtr();
  const int* inner = upper.innerIndexPtr();
  const double* value = upper.valuePtr();
  for (const int j : columns) {
    double* yj = y + static_cast<std::ptrdiff_t>(j) * stride;
    const int diagonal = outer[j + 1] - 1;
    double products[K];
    gather_products<K>(inner, value, outer[j], diagonal, y, stride, products);
    const double inverse_diagonal = 1.0 / value[diagonal];
    for (int k = 0; k < K; ++k) yj[k] = (yj[k] - products[k]) * inverse_diagonal;
  }
}

// Backward sweep Lᵀ x = y over `columns` (descending): a gather along column j of L (diagonal
// first), with L's columns stored last to first.
template <int K>
void backward_sweep(const std::size_t* begin, const std::size_t* end, const int* row, const double* value,
                    std::span<const int> columns, double* y, int stride) {
  for (auto it = columns.rbegin(); it != columns.rend(); ++it) {
    const int j = *it;
    double* yj = y + static_cast<std::ptrdiff_t>(j) * stride;
    const auto diagonal = static_cast<int>(begin[j]);
    double products[K];
    gather_products<K>(row, value, diagonal + 1, static_cast<int>(end[j]), y, stride, products);
    const double inverse_diagonal = 1.0 / value[diagonal];
    for (int k = 0; k < K; ++k) yj[k] = (yj[k] - products[k]) * inverse_diagonal;
  }
}

struct Sweeps {
  void (*forward)(const Eigen::SparseMatrix<double>&, std::span<const int>, double*, int);
  void (*backward)(const std::size_t*, const std::size_t*, const int*, const double*, std::span<const int>, double*, int);
};
template <int K>
constexpr Sweeps sweeps_for() {
  return {forward_sweep<K>, backward_sweep<K>};
}
constexpr int kMaxKernelColumns = 8;
constexpr Sweeps kSweeps[kMaxKernelColumns] = {sweeps_for<1>(), sweeps_for<2>(), sweeps_for<3>(), sweeps_for<4>(),
                                               sweeps_for<5>(), sweeps_for<6>(), sweeps_for<7>(), sweeps_for<8>()};

// Eigen's factor object keeps L in a protected member; moving it out avoids a 30 MB copy.
template <class Solver>
struct ExposeFactor : Solver {
  Eigen::SparseMatrix<double>& factor_matrix() { return this->m_matrix; }
};

void factor_with_eigen(const Eigen::SparseMatrix<double>& matrix, Eigen::SparseMatrix<double>& lower,
                       std::vector<int>& factor_row) {
  ExposeFactor<Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>>> solver;
  {
    const trace::Scope traced("analysis (ordering, elimination tree)", "set-up");
    solver.analyzePattern(matrix);
  }
  {
    const trace::Scope traced("numeric factorization", "set-up");
    solver.factorize(matrix);
  }
  if (solver.info() != Eigen::Success) {
    throw SolveError("the Laplacian system is not positive definite (Eigen SimplicialLLT failed)");
  }
  const auto& permutation = solver.permutationP().indices();
  factor_row.assign(permutation.data(), permutation.data() + permutation.size());
  lower = std::move(solver.factor_matrix());
}

#ifdef HDEFORM_WITH_CHOLMOD
struct CholmodFactorAccess : Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> {
  cholmod_factor* factor_handle() { return m_cholmodFactor; }
};

void factor_with_cholmod(const Eigen::SparseMatrix<double>& matrix, Eigen::SparseMatrix<double>& lower,
                         std::vector<int>& factor_row) {
  CholmodFactorAccess solver;
  solver.cholmod().print = 0;  // failures are reported as SolveError, not printed by CHOLMOD
  {
    const trace::Scope traced("analysis (ordering, supernodes)", "set-up");
    solver.analyzePattern(matrix);
  }
  {
    const trace::Scope traced("numeric factorization", "set-up");
    solver.factorize(matrix);
  }
  if (solver.info() != Eigen::Success) {
    throw SolveError("the Laplacian system is not positive definite (CHOLMOD supernodal LLT failed)");
  }
  cholmod_common& common = solver.cholmod();
  cholmod_factor* simplicial = cholmod_copy_factor(solver.factor_handle(), &common);
  // Packed, monotonic simplicial LLᵀ: CSC columns with the diagonal first, as the kernel reads it.
  if (simplicial == nullptr || !cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, simplicial, &common)) {
    if (simplicial != nullptr) cholmod_free_factor(&simplicial, &common);
    throw SolveError("CHOLMOD could not convert its factor (out of memory?)");
  }
  const auto n = static_cast<Eigen::Index>(simplicial->n);
  const auto* column_start = static_cast<const int*>(simplicial->p);
  const auto* row_index = static_cast<const int*>(simplicial->i);
  const auto* values = static_cast<const double*>(simplicial->x);
  const auto nonzeros = column_start[n];
  lower.resize(n, n);
  lower.resizeNonZeros(nonzeros);
  std::copy(column_start, column_start + n + 1, lower.outerIndexPtr());
  std::copy(row_index, row_index + nonzeros, lower.innerIndexPtr());
  std::copy(values, values + nonzeros, lower.valuePtr());
  // CHOLMOD's Perm[k] = i: unknown i is row k of the factor.
  const auto* permutation = static_cast<const int*>(simplicial->Perm);
  factor_row.assign(static_cast<std::size_t>(n), 0);
  for (Eigen::Index k = 0; k < n; ++k) factor_row[static_cast<std::size_t>(permutation[k])] = static_cast<int>(k);
  cholmod_free_factor(&simplicial, &common);
}
#endif

}  // namespace

std::string_view to_string(SolverBackend backend) { return backend == SolverBackend::Eigen ? "eigen" : "cholmod"; }

std::optional<SolverBackend> parse_backend(std::string_view name) {
  if (name == "eigen") return SolverBackend::Eigen;
  if (name == "cholmod") return SolverBackend::Cholmod;
  return std::nullopt;
}

bool backend_available(SolverBackend backend) {
#ifdef HDEFORM_WITH_CHOLMOD
  (void)backend;
  return true;
#else
  return backend == SolverBackend::Eigen;
#endif
}

SolverBackend default_backend() { return SolverBackend::Eigen; }

// The columns of L stored last to first, so that the backward sweep (j descending) streams
// through memory forwards: read backwards, it runs at half the speed.
struct ReversedColumns {
  std::vector<std::size_t> begin;  // column j: [begin[j], end[j]), diagonal first
  std::vector<std::size_t> end;
  std::vector<int> row;
  std::vector<double> value;
};

struct SparseCholesky::Factor {
  void adopt(const Eigen::SparseMatrix<double>& lower);
  void split_elimination_tree(const Eigen::SparseMatrix<double>& lower);

  Eigen::SparseMatrix<double> upper;  // Lᵀ in CSC: the rows of L, diagonal last; forward sweep
  ReversedColumns columns;            // L; backward sweep
  std::vector<int> factor_row;
  std::vector<std::vector<int>> subtrees;
  std::vector<int> top;
};

SparseCholesky::SparseCholesky() : factor_(std::make_unique<Factor>()) {}
SparseCholesky::~SparseCholesky() = default;
SparseCholesky::SparseCholesky(SparseCholesky&&) noexcept = default;
SparseCholesky& SparseCholesky::operator=(SparseCholesky&&) noexcept = default;

Eigen::Index SparseCholesky::size() const { return factor_ ? factor_->upper.rows() : 0; }
Eigen::Index SparseCholesky::factor_nonzeros() const { return factor_->upper.nonZeros(); }
const std::vector<int>& SparseCholesky::factor_row() const { return factor_->factor_row; }
std::size_t SparseCholesky::subtree_count() const { return factor_->subtrees.size(); }

void SparseCholesky::factor(const Eigen::SparseMatrix<double>& matrix, SolverBackend backend) {
  if (matrix.rows() != matrix.cols()) throw SolveError("cannot factor a non-square matrix");
  if (!backend_available(backend)) throw SolveError("this build has no " + std::string(to_string(backend)) + " backend");
  backend_ = backend;
  factor_ = std::make_unique<Factor>();
  Eigen::SparseMatrix<double> lower(0, 0);
  try {
    if (matrix.rows() > 0) {
#ifdef HDEFORM_WITH_CHOLMOD
      if (backend == SolverBackend::Cholmod) factor_with_cholmod(matrix, lower, factor_->factor_row);
      else factor_with_eigen(matrix, lower, factor_->factor_row);
#else
      factor_with_eigen(matrix, lower, factor_->factor_row);
#endif
    }
    factor_->adopt(lower);
  } catch (const std::bad_alloc&) {
    throw SolveError("out of memory while factoring a " + std::to_string(matrix.rows()) + "-unknown system");
  }
}

void SparseCholesky::Factor::adopt(const Eigen::SparseMatrix<double>& lower) {
  upper = lower.transpose();
  const auto n = static_cast<std::size_t>(lower.cols());
  columns.begin.resize(n);
  columns.end.resize(n);
  columns.row.resize(static_cast<std::size_t>(lower.nonZeros()));
  columns.value.resize(static_cast<std::size_t>(lower.nonZeros()));
  std::size_t next = 0;
  for (std::size_t j = n; j-- > 0;) {
    columns.begin[j] = next;
    for (int p = lower.outerIndexPtr()[j]; p < lower.outerIndexPtr()[j + 1]; ++p, ++next) {
      columns.row[next] = lower.innerIndexPtr()[p];
      columns.value[next] = lower.valuePtr()[p];
    }
    columns.end[j] = next;
  }
  split_elimination_tree(lower);
}

void SparseCholesky::Factor::split_elimination_tree(const Eigen::SparseMatrix<double>& lower) {
  subtrees.clear();
  top.clear();
  const int n = static_cast<int>(lower.cols());
  const int parts = tbb::this_task_arena::max_concurrency();
  const int* outer = lower.outerIndexPtr();
  const int* inner = lower.innerIndexPtr();
  if (parts <= 1 || n < 1024) {
    top.resize(static_cast<std::size_t>(n));
    std::iota(top.begin(), top.end(), 0);
    return;
  }
  // Elimination tree: the parent of column j is the first row below the diagonal in column j.
  std::vector<int> parent(static_cast<std::size_t>(n), -1);
  std::vector<double> subtree_work(static_cast<std::size_t>(n));
  std::vector<int> child_start(static_cast<std::size_t>(n) + 1, 0);
  for (int j = 0; j < n; ++j) {
    subtree_work[static_cast<std::size_t>(j)] += outer[j + 1] - outer[j];
    if (outer[j + 1] - outer[j] > 1) {
      const int p = inner[outer[j] + 1];
      parent[static_cast<std::size_t>(j)] = p;
      subtree_work[static_cast<std::size_t>(p)] += subtree_work[static_cast<std::size_t>(j)];
      ++child_start[static_cast<std::size_t>(p) + 1];
    }
  }
  for (int j = 0; j < n; ++j) child_start[static_cast<std::size_t>(j) + 1] += child_start[static_cast<std::size_t>(j)];
  std::vector<int> children(static_cast<std::size_t>(child_start.back()));
  {
    std::vector<int> fill(child_start.begin(), child_start.end() - 1);
    for (int j = 0; j < n; ++j) {
      if (parent[static_cast<std::size_t>(j)] >= 0) children[static_cast<std::size_t>(fill[static_cast<std::size_t>(parent[static_cast<std::size_t>(j)])]++)] = j;
    }
  }

  // Proportional splitting: take the largest subtree's root into the top part until every
  // subtree is small enough for an even packing onto the workers.
  const double total = static_cast<double>(lower.nonZeros());
  const double grain = total / (16.0 * parts);
  const double top_limit = 0.25 * total;
  std::vector<std::pair<double, int>> heap;
  for (int j = 0; j < n; ++j) {
    if (parent[static_cast<std::size_t>(j)] < 0) heap.emplace_back(subtree_work[static_cast<std::size_t>(j)], j);
  }
  std::make_heap(heap.begin(), heap.end());
  double top_work = 0.0;
  while (!heap.empty() && heap.front().first > grain && top_work < top_limit) {
    std::pop_heap(heap.begin(), heap.end());
    const int root = heap.back().second;
    heap.pop_back();
    top.push_back(root);
    top_work += outer[root + 1] - outer[root];
    for (int c = child_start[static_cast<std::size_t>(root)]; c < child_start[static_cast<std::size_t>(root) + 1]; ++c) {
      const int child = children[static_cast<std::size_t>(c)];
      heap.emplace_back(subtree_work[static_cast<std::size_t>(child)], child);
      std::push_heap(heap.begin(), heap.end());
    }
  }
  // Largest first onto the least loaded worker; ties by root index keep it deterministic.
  std::sort(heap.begin(), heap.end(), [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
  subtrees.assign(static_cast<std::size_t>(parts), {});
  std::vector<double> load(static_cast<std::size_t>(parts), 0.0);
  std::vector<int> stack;
  for (const auto& [work, root] : heap) {
    const auto worker = static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[worker] += work;
    stack.assign(1, root);
    while (!stack.empty()) {
      const int node = stack.back();
      stack.pop_back();
      subtrees[worker].push_back(node);
      for (int c = child_start[static_cast<std::size_t>(node)]; c < child_start[static_cast<std::size_t>(node) + 1]; ++c) {
        stack.push_back(children[static_cast<std::size_t>(c)]);
      }
    }
  }
  for (auto& subtree : subtrees) std::sort(subtree.begin(), subtree.end());
  std::sort(top.begin(), top.end());
}

double SparseCholesky::top_fraction() const {
  const Factor& f = *factor_;
  if (f.upper.nonZeros() == 0) return 0.0;
  double top = 0.0;
  for (const int j : f.top) top += static_cast<double>(f.columns.end[static_cast<std::size_t>(j)] - f.columns.begin[static_cast<std::size_t>(j)]);
  return top / static_cast<double>(f.upper.nonZeros());
}

void SparseCholesky::solve_block(double* block, int columns, int stride) const {
  const Factor& f = *factor_;
  for (int first = 0; first < columns; first += kMaxKernelColumns) {
    const Sweeps& sweeps = kSweeps[std::min(kMaxKernelColumns, columns - first) - 1];
    double* y = block + first;
    // Each sweep of each part is an event of the trace, on the thread that ran it.
    auto each_subtree = [&](const char* name, auto&& sweep) {
      if (f.subtrees.empty()) return;
      tbb::parallel_for(
          std::size_t{0}, f.subtrees.size(),
          [&](std::size_t part) {
            const trace::Scope traced(name, "solve", static_cast<std::int64_t>(part));
            sweep(f.subtrees[part]);
          },
          tbb::static_partitioner());
    };
    auto backward = [&](std::span<const int> part) {
      const auto& l = f.columns;
      sweeps.backward(l.begin.data(), l.end.data(), l.row.data(), l.value.data(), part, y, stride);
    };
    each_subtree("forward sweep, subtree", [&](const std::vector<int>& part) { sweeps.forward(f.upper, part, y, stride); });
    {
      const trace::Scope traced("forward and backward sweeps, top", "solve");
      sweeps.forward(f.upper, f.top, y, stride);
      backward(f.top);
    }
    each_subtree("backward sweep, subtree", [&](const std::vector<int>& part) { backward(part); });
  }
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& rhs) const {
  const auto n = size();
  const int columns = static_cast<int>(rhs.cols());
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block(n, columns);
  for (Eigen::Index i = 0; i < n; ++i) block.row(factor_->factor_row[static_cast<std::size_t>(i)]) = rhs.row(i);
  solve_block(block.data(), columns, columns);
  Eigen::MatrixXd solution(n, columns);
  for (Eigen::Index i = 0; i < n; ++i) solution.row(i) = block.row(factor_->factor_row[static_cast<std::size_t>(i)]);
  return solution;
}

std::string_view to_string(SolveSchedule schedule) {
  switch (schedule) {
    case SolveSchedule::Blocked: return "blocked";
    case SolveSchedule::PerColumn: return "per-column";
    case SolveSchedule::ThreadGroups: return "thread-groups";
  }
  return "?";
}

std::optional<SolveSchedule> parse_schedule(std::string_view name) {
  for (auto schedule : {SolveSchedule::Blocked, SolveSchedule::PerColumn, SolveSchedule::ThreadGroups}) {
    if (name == to_string(schedule)) return schedule;
  }
  return std::nullopt;
}

SolveSchedule default_schedule() { return SolveSchedule::Blocked; }

ColumnBlocks::ColumnBlocks(Eigen::Index rows, int columns, SolveSchedule schedule, int threads) : rows_(rows) {
  if (threads <= 0) threads = tbb::this_task_arena::max_concurrency();
  int group_count = 1;
  if (schedule == SolveSchedule::PerColumn) group_count = columns;
  if (schedule == SolveSchedule::ThreadGroups) group_count = std::min(columns, std::max(1, threads));
  group_count = std::max(1, std::min(group_count, std::max(columns, 1)));
  groups_.resize(static_cast<std::size_t>(group_count));
  group_of_column_.resize(static_cast<std::size_t>(columns));
  int column = 0;
  for (int g = 0; g < group_count; ++g) {
    // Earlier groups take the remainder: 3 columns on 2 threads → {2, 1}.
    const int width = columns / group_count + (g < columns % group_count ? 1 : 0);
    auto& group = groups_[static_cast<std::size_t>(g)];
    group.columns = width;
    group.values.assign(static_cast<std::size_t>(rows * width), 0.0);
    for (int k = 0; k < width; ++k, ++column) group_of_column_[static_cast<std::size_t>(column)] = {g, k};
  }
}

void ColumnBlocks::solve_group(const SparseCholesky& factor, int group_index) {
  auto& group = groups_[static_cast<std::size_t>(group_index)];
  if (group.columns > 0) factor.solve_block(group.values.data(), group.columns, group.columns);
}

void ColumnBlocks::solve(const SparseCholesky& factor) {
  tbb::parallel_for(0, groups(), [&](int g) { solve_group(factor, g); });
}

}  // namespace hdeform

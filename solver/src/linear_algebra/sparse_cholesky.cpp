#include "hdeform/sparse_cholesky.h"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <numeric>
#include <span>
#include <string>

#include "hdeform/errors.h"
#include "hdeform/trace.h"
#include "factor_memory.h"
#include "single_precision_factor.h"
#include "tree_factorization.h"
#include "triangular_sweeps.h"

#ifdef HDEFORM_WITH_CHOLMOD
#include <Eigen/CholmodSupport>
#endif

namespace hdeform {
namespace {

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

std::string_view to_string(SolverBackend backend) {
  switch (backend) {
    case SolverBackend::Tree: return "tree";
    case SolverBackend::Eigen: return "eigen";
    case SolverBackend::Cholmod: return "cholmod";
  }
  return "?";
}

std::optional<SolverBackend> parse_backend(std::string_view name) {
  for (const auto backend : kSolverBackends) {
    if (name == to_string(backend)) return backend;
  }
  return std::nullopt;
}

bool backend_available(SolverBackend backend) {
#ifdef HDEFORM_WITH_CHOLMOD
  (void)backend;
  return true;
#else
  return backend != SolverBackend::Cholmod;
#endif
}

SolverBackend default_backend() { return SolverBackend::Tree; }

struct SparseCholesky::Analysis {
  std::vector<int> factor_row;
  // The pattern analysed (compressed outer and inner indices), to recognise it again; empty
  // when the analysis came from another backend's factor and cannot be reused.
  std::vector<int> matrix_outer;
  std::vector<int> matrix_inner;
  detail::FactorPattern pattern;

  bool analysed(const Eigen::SparseMatrix<double>& matrix) const {
    if (matrix_outer.empty() || !matrix.isCompressed() || matrix.rows() + 1 != static_cast<Eigen::Index>(matrix_outer.size())) return false;
    return std::equal(matrix_outer.begin(), matrix_outer.end(), matrix.outerIndexPtr()) &&
           matrix.nonZeros() == static_cast<Eigen::Index>(matrix_inner.size()) &&
           std::equal(matrix_inner.begin(), matrix_inner.end(), matrix.innerIndexPtr());
  }
};

struct SparseCholesky::Factor {
  std::shared_ptr<const Analysis> analysis = std::make_shared<Analysis>();
  detail::UninitializedVector<double> row_value;     // L by rows (analysis->pattern.row_start/row_column); forward sweep
  detail::UninitializedVector<double> column_value;  // L by stored columns (pattern.column_begin/end and rows); backward sweep
  bool reused_analysis = false;
  // With FactorPrecision::Single: L in single precision (the double values above are released)
  // and the refinement of its solves; null when the solves use the double values.
  std::unique_ptr<detail::SingleFactor> single;
  std::string precision_note;  // why single precision was asked for and not used
};

namespace {

// Another backend's L (CSC, diagonal first) in the layouts the sweeps read.
void adopt(const Eigen::SparseMatrix<double>& lower, std::vector<int> factor_row, SparseCholesky::Factor& factor) {
  auto analysis = std::make_shared<SparseCholesky::Analysis>();
  analysis->factor_row = std::move(factor_row);
  detail::FactorPattern& pattern = analysis->pattern;
  const Eigen::SparseMatrix<double> upper = lower.transpose();
  const auto n = static_cast<std::size_t>(lower.cols());
  const auto nonzeros = static_cast<std::size_t>(lower.nonZeros());
  pattern.row_start.assign(upper.outerIndexPtr(), upper.outerIndexPtr() + n + 1);
  pattern.row_column.assign(upper.innerIndexPtr(), upper.innerIndexPtr() + nonzeros);
  factor.row_value.assign(upper.valuePtr(), upper.valuePtr() + nonzeros);
  pattern.column_begin.resize(n);
  pattern.column_end.resize(n);
  pattern.rows_of_column.resize(n);
  pattern.rows.resize(nonzeros);  // one row list per column: no sharing
  factor.column_value.resize(nonzeros);
  pattern.parent.assign(n, -1);
  const int* outer = lower.outerIndexPtr();
  std::size_t next = 0;
  for (std::size_t j = n; j-- > 0;) {
    pattern.column_begin[j] = next;
    pattern.rows_of_column[j] = next;
    for (int p = outer[j]; p < outer[j + 1]; ++p, ++next) {
      pattern.rows[next] = lower.innerIndexPtr()[p];
      factor.column_value[next] = lower.valuePtr()[p];
    }
    pattern.column_end[j] = next;
    // The parent of column j is the first row below the diagonal.
    if (outer[j + 1] - outer[j] > 1) pattern.parent[j] = lower.innerIndexPtr()[outer[j] + 1];
  }
  detail::schedule_sweeps(pattern, tbb::this_task_arena::max_concurrency());
  factor.analysis = std::move(analysis);
}

// factor_row from ranks: unknowns in ascending rank, ties by index.
std::vector<int> rows_of_ranks(std::span<const int> rank) {
  std::vector<int> order(rank.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const auto ra = rank[static_cast<std::size_t>(a)], rb = rank[static_cast<std::size_t>(b)];
    return ra != rb ? ra < rb : a < b;
  });
  std::vector<int> factor_row(rank.size());
  for (std::size_t k = 0; k < order.size(); ++k) factor_row[static_cast<std::size_t>(order[k])] = static_cast<int>(k);
  return factor_row;
}

SolveError not_definite() { return SolveError("the Laplacian system is not positive definite (the supernodal factorization failed)"); }

// Keeps L in single precision when the probe says it serves this matrix, else in double and says
// why. With `refactor` (the tree backend, whose double values are already released) the double
// factor is computed again from A when the probe refuses; otherwise (another backend's L,
// rounded) the double values are kept until the probe has spoken.
void keep_single_precision(detail::UninitializedVector<float> rows, detail::UninitializedVector<float> columns,
                           detail::PermutedMatrix permuted, SparseCholesky::Factor& factor, bool refactor) {
  const detail::FactorPattern& pattern = factor.analysis->pattern;
  auto single = std::make_unique<detail::SingleFactor>(pattern, std::move(rows), std::move(columns), std::move(permuted));
  if (auto reason = single->calibrate(pattern)) {
    factor.precision_note = std::move(*reason);
    if (refactor) {
      const trace::Scope traced("numeric factorization, in double", "set-up");
      if (!detail::factor_numeric(single->matrix(), pattern, factor.row_value, factor.column_value)) {
        throw not_definite();
      }
    }
    return;
  }
  factor.single = std::move(single);
  detail::UninitializedVector<double>().swap(factor.row_value);
  detail::UninitializedVector<double>().swap(factor.column_value);
}

void factor_with_tree(const Eigen::SparseMatrix<double>& matrix, std::span<const int> ordering,
                      const std::shared_ptr<const SparseCholesky::Analysis>& reuse, FactorPrecision precision, SparseCholesky::Factor& factor) {
  std::shared_ptr<const SparseCholesky::Analysis> analysis;
  detail::PermutedMatrix permuted;
  if (reuse && reuse->analysed(matrix)) {
    const trace::Scope traced("permuted matrix (analysis reused)", "set-up");
    analysis = reuse;
    permuted = detail::permuted_matrix(matrix, analysis->factor_row);
    factor.reused_analysis = true;
  } else {
    auto fresh = std::make_shared<SparseCholesky::Analysis>();
    if (ordering.empty()) {
      fresh->factor_row = elimination_ranks(matrix);
    }
    const trace::Scope traced("analysis (elimination tree, pattern of L)", "set-up");
    if (!ordering.empty()) fresh->factor_row = rows_of_ranks(ordering);
    Eigen::SparseMatrix<double> compressed;
    const Eigen::SparseMatrix<double>* pattern_of = &matrix;
    if (!matrix.isCompressed()) {
      compressed = matrix;
      compressed.makeCompressed();
      pattern_of = &compressed;
    }
    fresh->matrix_outer.assign(pattern_of->outerIndexPtr(), pattern_of->outerIndexPtr() + matrix.cols() + 1);
    fresh->matrix_inner.assign(pattern_of->innerIndexPtr(), pattern_of->innerIndexPtr() + pattern_of->nonZeros());
    permuted = detail::permuted_matrix(matrix, fresh->factor_row);
    fresh->pattern = detail::analyse_pattern(permuted, tbb::this_task_arena::max_concurrency());
    analysis = std::move(fresh);
  }
  factor.analysis = analysis;
  const detail::FactorPattern& pattern = analysis->pattern;
  detail::check_factor_memory(matrix.rows(), detail::factor_value_bytes(pattern.nonzeros()), detail::available_memory_bytes());
  if (precision == FactorPrecision::Double) {
    const trace::Scope traced("numeric factorization", "set-up");
    if (!detail::factor_numeric(permuted, pattern, factor.row_value, factor.column_value)) throw not_definite();
    return;
  }
  // The rows are never read back while factoring: written in single precision straight away. The
  // columns are rounded after, and their double values released before the probe.
  detail::UninitializedVector<float> rows;
  {
    const trace::Scope traced("numeric factorization, rows in single precision", "set-up");
    if (!detail::factor_numeric(permuted, pattern, rows, factor.column_value)) throw not_definite();
  }
  auto columns = detail::SingleFactor::rounded(factor.column_value);
  detail::UninitializedVector<double>().swap(factor.column_value);
  keep_single_precision(std::move(rows), std::move(columns), std::move(permuted), factor, true);
}

}  // namespace

SparseCholesky::SparseCholesky() : factor_(std::make_unique<Factor>()) {}
SparseCholesky::~SparseCholesky() = default;
SparseCholesky::SparseCholesky(SparseCholesky&&) noexcept = default;
SparseCholesky& SparseCholesky::operator=(SparseCholesky&&) noexcept = default;

Eigen::Index SparseCholesky::size() const { return factor_ ? factor_->analysis->pattern.size() : 0; }
Eigen::Index SparseCholesky::factor_nonzeros() const { return static_cast<Eigen::Index>(factor_->analysis->pattern.nonzeros()); }
const std::vector<int>& SparseCholesky::factor_row() const { return factor_->analysis->factor_row; }
std::size_t SparseCholesky::subtree_count() const { return factor_->analysis->pattern.schedule.subtrees.size(); }
std::shared_ptr<const SparseCholesky::Analysis> SparseCholesky::analysis() const {
  return factor_->analysis->matrix_outer.empty() ? nullptr : factor_->analysis;
}
bool SparseCholesky::reused_analysis() const { return factor_->reused_analysis; }
FactorPrecision SparseCholesky::precision() const { return factor_->single ? FactorPrecision::Single : FactorPrecision::Double; }
const std::string& SparseCholesky::precision_note() const { return factor_->precision_note; }

SparseCholesky::Refinement SparseCholesky::refinement() const {
  if (!factor_->single) return {};
  const detail::SingleFactor& single = *factor_->single;
  const auto counts = single.counts();
  return {counts.solves, counts.corrections, counts.most_corrections, counts.stalled, single.contraction()};
}

std::string_view to_string(FactorPrecision precision) { return precision == FactorPrecision::Single ? "single" : "double"; }

std::optional<FactorPrecision> parse_precision(std::string_view name) {
  for (const auto precision : {FactorPrecision::Double, FactorPrecision::Single}) {
    if (name == to_string(precision)) return precision;
  }
  return std::nullopt;
}

void SparseCholesky::factor(const Eigen::SparseMatrix<double>& matrix, SolverBackend backend, std::span<const int> ordering,
                            const std::shared_ptr<const Analysis>& reuse, FactorPrecision precision) {
  if (matrix.rows() != matrix.cols()) throw SolveError("cannot factor a non-square matrix");
  if (!backend_available(backend)) throw SolveError("this build has no " + std::string(to_string(backend)) + " backend");
  if (!ordering.empty() && ordering.size() != static_cast<std::size_t>(matrix.rows())) {
    throw std::invalid_argument("SparseCholesky::factor: the ordering has " + std::to_string(ordering.size()) + " ranks for " +
                                std::to_string(matrix.rows()) + " unknowns");
  }
  backend_ = backend;
  factor_ = std::make_unique<Factor>();
  if (matrix.rows() == 0) return;
  try {
    if (backend == SolverBackend::Tree) {
      factor_with_tree(matrix, ordering, reuse, precision, *factor_);
    } else {
      Eigen::SparseMatrix<double> lower(0, 0);
      std::vector<int> factor_row;
#ifdef HDEFORM_WITH_CHOLMOD
      if (backend == SolverBackend::Cholmod) factor_with_cholmod(matrix, lower, factor_row);
      else factor_with_eigen(matrix, lower, factor_row);
#else
      factor_with_eigen(matrix, lower, factor_row);
#endif
      const trace::Scope traced("factor layouts", "set-up");
      adopt(lower, std::move(factor_row), *factor_);
      if (precision == FactorPrecision::Single) {
        keep_single_precision(detail::SingleFactor::rounded(factor_->row_value), detail::SingleFactor::rounded(factor_->column_value),
                              detail::permuted_matrix(matrix, factor_->analysis->factor_row), *factor_, false);
      }
    }
  } catch (const std::bad_alloc&) {
    throw SolveError("out of memory while factoring a " + std::to_string(matrix.rows()) + "-unknown system");
  }
}

double SparseCholesky::top_fraction() const {
  const auto& pattern = factor_->analysis->pattern;
  if (pattern.nonzeros() == 0) return 0.0;
  double top = 0.0;
  for (const int j : pattern.schedule.top) {
    top += static_cast<double>(pattern.column_end[static_cast<std::size_t>(j)] - pattern.column_begin[static_cast<std::size_t>(j)]);
  }
  return top / static_cast<double>(pattern.nonzeros());
}

void SparseCholesky::solve_block(double* block, int columns, int stride) const {
  const Factor& f = *factor_;
  const detail::FactorPattern& pattern = f.analysis->pattern;
  if (f.single) f.single->solve(pattern, block, columns, stride);
  else detail::solve_with_factor<double>(pattern, f.row_value.data(), f.column_value.data(), block, columns, stride);
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& rhs) const {
  const auto n = size();
  const int columns = static_cast<int>(rhs.cols());
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block = Eigen::MatrixXd::Zero(n, fast_solve_stride(columns));
  for (Eigen::Index i = 0; i < n; ++i) block.row(factor_row()[static_cast<std::size_t>(i)]).head(columns) = rhs.row(i);
  solve_block(block.data(), columns, static_cast<int>(block.cols()));
  Eigen::MatrixXd solution(n, columns);
  for (Eigen::Index i = 0; i < n; ++i) solution.row(i) = block.row(factor_row()[static_cast<std::size_t>(i)]).head(columns);
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
    group.stride = SparseCholesky::fast_solve_stride(width);
    group.values.assign(static_cast<std::size_t>(rows * group.stride), 0.0);
    for (int k = 0; k < width; ++k, ++column) group_of_column_[static_cast<std::size_t>(column)] = {g, k};
  }
}

void ColumnBlocks::solve_group(const SparseCholesky& factor, int group_index) {
  auto& group = groups_[static_cast<std::size_t>(group_index)];
  if (group.columns > 0) factor.solve_block(group.values.data(), group.columns, group.stride);
}

void ColumnBlocks::solve(const SparseCholesky& factor) {
  tbb::parallel_for(0, groups(), [&](int g) { solve_group(factor, g); });
}

}  // namespace hdeform

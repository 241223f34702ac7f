#include "hdeform/sparse_cholesky.h"

#include <Eigen/SparseCholesky>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <string>

#include "hdeform/errors.h"

#ifdef HDEFORM_WITH_CHOLMOD
#include <Eigen/CholmodSupport>
#endif

namespace hdeform {
namespace {

// Forward then backward substitution with L (CSC, diagonal first) for K interleaved columns.
// Forward sweep scatters column j into the rows below; backward sweep gathers row j of Lᵀ.
template <int K>
void substitute(const Eigen::SparseMatrix<double>& lower, double* y, int stride) {
  const int n = static_cast<int>(lower.cols());
  const int* outer = lower.outerIndexPtr();
  const int* inner = lower.innerIndexPtr();
  const double* value = lower.valuePtr();
  for (int j = 0; j < n; ++j) {
    int p = outer[j];
    const double inverse_diagonal = 1.0 / value[p];
    double* yj = y + static_cast<std::ptrdiff_t>(j) * stride;
    double pivot[K];
    for (int k = 0; k < K; ++k) pivot[k] = yj[k] = yj[k] * inverse_diagonal;
    for (++p; p < outer[j + 1]; ++p) {
      const double l = value[p];
      double* yi = y + static_cast<std::ptrdiff_t>(inner[p]) * stride;
      for (int k = 0; k < K; ++k) yi[k] -= l * pivot[k];
    }
  }
  for (int j = n - 1; j >= 0; --j) {
    const int first = outer[j];
    double* yj = y + static_cast<std::ptrdiff_t>(j) * stride;
    double sum[K];
    for (int k = 0; k < K; ++k) sum[k] = yj[k];
    for (int p = first + 1; p < outer[j + 1]; ++p) {
      const double l = value[p];
      const double* yi = y + static_cast<std::ptrdiff_t>(inner[p]) * stride;
      for (int k = 0; k < K; ++k) sum[k] -= l * yi[k];
    }
    const double inverse_diagonal = 1.0 / value[first];
    for (int k = 0; k < K; ++k) yj[k] = sum[k] * inverse_diagonal;
  }
}

using Kernel = void (*)(const Eigen::SparseMatrix<double>&, double*, int);
constexpr int kMaxKernelColumns = 8;
constexpr Kernel kKernels[kMaxKernelColumns] = {substitute<1>, substitute<2>, substitute<3>, substitute<4>,
                                                substitute<5>, substitute<6>, substitute<7>, substitute<8>};

// Eigen's factor object keeps L in a protected member; moving it out avoids a 30 MB copy.
template <class Solver>
struct ExposeFactor : Solver {
  Eigen::SparseMatrix<double>& factor_matrix() { return this->m_matrix; }
};

void factor_with_eigen(const Eigen::SparseMatrix<double>& matrix, Eigen::SparseMatrix<double>& lower,
                       std::vector<int>& factor_row) {
  ExposeFactor<Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>>> solver;
  solver.compute(matrix);
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
  solver.compute(matrix);
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

void SparseCholesky::factor(const Eigen::SparseMatrix<double>& matrix, SolverBackend backend) {
  if (matrix.rows() != matrix.cols()) throw SolveError("cannot factor a non-square matrix");
  if (!backend_available(backend)) throw SolveError("this build has no " + std::string(to_string(backend)) + " backend");
  backend_ = backend;
  lower_.resize(0, 0);
  factor_row_.clear();
  if (matrix.rows() == 0) return;
  try {
#ifdef HDEFORM_WITH_CHOLMOD
    if (backend == SolverBackend::Cholmod) {
      factor_with_cholmod(matrix, lower_, factor_row_);
      return;
    }
#endif
    factor_with_eigen(matrix, lower_, factor_row_);
  } catch (const std::bad_alloc&) {
    throw SolveError("out of memory while factoring a " + std::to_string(matrix.rows()) + "-unknown system");
  }
}

void SparseCholesky::solve_block(double* block, int columns, int stride) const {
  for (int first = 0; first < columns; first += kMaxKernelColumns) {
    const int width = std::min(kMaxKernelColumns, columns - first);
    kKernels[width - 1](lower_, block + first, stride);
  }
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& rhs) const {
  const auto n = size();
  const int columns = static_cast<int>(rhs.cols());
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block(n, columns);
  for (Eigen::Index i = 0; i < n; ++i) block.row(factor_row_[static_cast<std::size_t>(i)]) = rhs.row(i);
  solve_block(block.data(), columns, columns);
  Eigen::MatrixXd solution(n, columns);
  for (Eigen::Index i = 0; i < n; ++i) solution.row(i) = block.row(factor_row_[static_cast<std::size_t>(i)]);
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

SolveSchedule default_schedule() { return SolveSchedule::ThreadGroups; }

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

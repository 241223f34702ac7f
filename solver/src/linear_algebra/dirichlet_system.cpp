#include "hdeform/dirichlet_system.h"

#include <tbb/parallel_for.h>

#include <chrono>
#include <stdexcept>
#include "hdeform/stopwatch.h"

namespace hdeform {

DirichletSystem::DirichletSystem(const Eigen::SparseMatrix<double>& laplacian, const VertexPartition& partition,
                                 SolverBackend backend, std::span<const int> vertex_rank,
                                 const std::shared_ptr<const SparseCholesky::Analysis>& reuse, FactorPrecision precision) {
  const auto n = static_cast<std::size_t>(laplacian.rows());
  const auto& free = partition.free_vertices;
  std::vector<int> free_index(n, -1);
  for (std::size_t k = 0; k < free.size(); ++k) free_index[static_cast<std::size_t>(free[k])] = static_cast<int>(k);

  // L_ff in free-vertex order; columns of the symmetric L are its rows.
  Eigen::SparseMatrix<double> free_block(static_cast<Eigen::Index>(free.size()), static_cast<Eigen::Index>(free.size()));
  if (!free.empty()) {  // (Eigen's makeCompressed reads past a matrix with no columns)
    Eigen::VectorXi per_column(static_cast<Eigen::Index>(free.size()));
    for (std::size_t k = 0; k < free.size(); ++k) {
      per_column(static_cast<Eigen::Index>(k)) = static_cast<int>(laplacian.innerVector(free[k]).nonZeros());
    }
    free_block.reserve(per_column);
    for (std::size_t k = 0; k < free.size(); ++k) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(laplacian, free[k]); it; ++it) {
        const int row = free_index[static_cast<std::size_t>(it.row())];
        if (row >= 0) free_block.insert(row, static_cast<Eigen::Index>(k)) = it.value();
      }
    }
    free_block.makeCompressed();
  }
  const auto factor_start = std::chrono::steady_clock::now();
  std::vector<int> free_rank;
  // Without an order given, the whole Laplacian's is computed: every system on a mesh then
  // eliminates in the same order (the editor's, the batch commands', the field's), so their
  // results agree to the last bit.
  std::vector<int> own_rank;
  if (vertex_rank.empty() && backend == SolverBackend::Tree && !free.empty()) {
    own_rank = elimination_ranks(laplacian);
    vertex_rank = own_rank;
  }
  if (!vertex_rank.empty()) {
    if (vertex_rank.size() != n) throw std::invalid_argument("DirichletSystem: the elimination order is of another mesh");
    free_rank.resize(free.size());
    for (std::size_t k = 0; k < free.size(); ++k) free_rank[k] = vertex_rank[static_cast<std::size_t>(free[k])];
  }
  factor_.factor(free_block, backend, free_rank, reuse, precision);
  factor_ms_ = milliseconds_since(factor_start);

  row_of_vertex_.assign(n, -1);
  vertex_of_row_.assign(free.size(), -1);
  for (std::size_t k = 0; k < free.size(); ++k) {
    const int row = free.empty() ? 0 : factor_.factor_row()[k];
    row_of_vertex_[static_cast<std::size_t>(free[k])] = row;
    vertex_of_row_[static_cast<std::size_t>(row)] = free[k];
  }

  coupling_start_.assign(free.size() + 1, 0);
  for (std::size_t row = 0; row < free.size(); ++row) {
    std::size_t count = 0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(laplacian, vertex_of_row_[row]); it; ++it) {
      if (free_index[static_cast<std::size_t>(it.row())] < 0) ++count;
    }
    coupling_start_[row + 1] = coupling_start_[row] + count;
  }
  coupling_.resize(coupling_start_.back());
  for (std::size_t row = 0; row < free.size(); ++row) {
    std::size_t slot = coupling_start_[row];
    for (Eigen::SparseMatrix<double>::InnerIterator it(laplacian, vertex_of_row_[row]); it; ++it) {
      if (free_index[static_cast<std::size_t>(it.row())] < 0) coupling_[slot++] = {static_cast<int>(it.row()), it.value()};
    }
  }
}

void DirichletSystem::solve(Eigen::MatrixXd& values, const Eigen::MatrixXd* source) const {
  const int columns = static_cast<int>(values.cols());
  const auto rows = free_count();
  if (rows == 0 || columns == 0) return;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block(rows, SparseCholesky::fast_solve_stride(columns));
  tbb::parallel_for(Eigen::Index{0}, rows, [&](Eigen::Index row) {
    const int vertex = vertex_of_row_[static_cast<std::size_t>(row)];
    for (int c = 0; c < columns; ++c) {
      double value = source != nullptr ? (*source)(vertex, c) : 0.0;
      for (const auto& entry : coupling(static_cast<int>(row))) value -= entry.weight * values(entry.vertex, c);
      block(row, c) = value;
    }
    for (Eigen::Index pad = columns; pad < block.cols(); ++pad) block(row, pad) = 0.0;
  });
  factor_.solve_block(block.data(), columns, static_cast<int>(block.cols()));
  // Back into the column-major values a tile of rows at a time: a row written whole touches a
  // cache line per column, a tile writes each line it touches several times in a row.
  constexpr Eigen::Index kTile = 64;
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, rows, kTile), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (int c = 0; c < columns; ++c) {
      for (Eigen::Index row = range.begin(); row != range.end(); ++row) values(vertex_of_row_[static_cast<std::size_t>(row)], c) = block(row, c);
    }
  });
}

}  // namespace hdeform

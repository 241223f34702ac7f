#pragma once
// The pieces of a sparse Cholesky factorization that run in parallel over disjoint subtrees of
// the elimination tree (private to sparse_cholesky.cpp).
//
// L is computed row by row ("up-looking"): row k solves a triangular system whose pattern is the
// set of k's descendants reached from the entries of A's column k, so every row reads and writes
// only the columns of its own subtree. Disjoint subtrees therefore factor concurrently, and the
// rows above them (the top) follow in ascending order. Each row's arithmetic is the same whatever
// the schedule, so the factor is bit-identical for any number of threads.
#include <Eigen/SparseCore>

#include <cstddef>
#include <span>
#include <vector>

namespace hdeform::detail {

// Rows of the elimination tree split for `parts` workers: each subtree list (ascending) is closed
// under descendants; `top` (ascending) holds every other row, each an ancestor of subtree roots.
struct EliminationSchedule {
  std::vector<std::vector<int>> subtrees;
  std::vector<int> top;
};

// parent[j]: j's parent in the elimination tree, −1 for a root; work[j]: the cost of row j.
EliminationSchedule split_elimination_tree(std::span<const int> parent, std::span<const double> work, int parts);

// The pattern of L in the two layouts the solve sweeps read, and the tree that orders them.
struct FactorPattern {
  // L by rows (Lᵀ in CSC): row k is [row_start[k], row_start[k+1]), columns ascending, diagonal last.
  std::vector<int> row_start;
  std::vector<int> row_column;
  // L by columns, the columns stored last to first so that the backward sweep streams forwards:
  // column j is [column_begin[j], column_end[j]), rows ascending, diagonal first.
  std::vector<std::size_t> column_begin;
  std::vector<std::size_t> column_end;
  std::vector<int> column_row;
  std::vector<int> parent;
  EliminationSchedule schedule;         // for the solve sweeps: rows weighted by their column's length
  EliminationSchedule factor_schedule;  // for the factorization: rows weighted by their updates' flops

  int size() const { return static_cast<int>(parent.size()); }
  std::size_t nonzeros() const { return row_column.size(); }
};

// The upper triangle of P A Pᵀ by columns (rows ascending, diagonal last) for A symmetric with
// both triangles stored and factor_row[i] the row of unknown i: what the analysis and the
// numeric factorization read.
struct PermutedUpper {
  std::vector<int> start;
  std::vector<int> row;
  std::vector<double> value;
};
PermutedUpper permuted_upper(const Eigen::SparseMatrix<double>& matrix, std::span<const int> factor_row);

// Elimination tree, pattern of L and its split for `parts` workers.
FactorPattern analyse_pattern(const PermutedUpper& upper, int parts);

// L's values in both layouts of `pattern` (row_value by rows, column_value by stored columns).
// Returns false when the matrix is not positive definite.
bool factor_numeric(const PermutedUpper& upper, const FactorPattern& pattern, std::vector<double>& row_value,
                    std::vector<double>& column_value);

}  // namespace hdeform::detail

#pragma once
// The pieces of a sparse Cholesky factorization that run in parallel over disjoint subtrees of
// the elimination tree (private to sparse_cholesky.cpp).
//
// L is computed supernode by supernode, left-looking: a supernode is a run of consecutive columns
// whose rows below the diagonal are the same (column j's rows are column j+1's and j+1 itself),
// factored as one dense panel after subtracting the updates of every earlier supernode with rows
// in its columns. A supernode reads only its descendants in the elimination tree, so disjoint
// subtrees factor concurrently and the supernodes above them (the top) follow. Each supernode
// applies its updates in ascending order of the updating supernode whatever the schedule, so the
// factor is bit-identical for any number of threads.
//
// The factor is written straight into the two layouts the solve sweeps read (L by rows, and L by
// columns stored last to first); a supernode's panel is a column-major block only while it is
// being computed.
#include <Eigen/SparseCore>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include <atomic>
#include <cstddef>
#include <span>
#include <vector>

#include "uninitialized_vector.h"

namespace hdeform::detail {

// The top is itself a forest, cut into chains: runs of nodes each the only top child of the next.
// Sibling chains share no node, so a sweep may run them concurrently once their children are done
// (forward) or their parent is (backward), each node's arithmetic unchanged.
struct TopChains {
  std::vector<int> nodes;        // chain c: nodes[node_start[c] .. node_start[c+1]), ascending
  std::vector<int> node_start;
  std::vector<int> children;     // chain c's child chains: children[child_start[c] .. child_start[c+1])
  std::vector<int> child_start;
  std::vector<int> roots;        // chains whose last node is a root of the tree
  std::vector<double> work;      // of chain c and every chain below it

  int count() const { return static_cast<int>(node_start.size()) - 1; }
  std::span<const int> nodes_of(int c) const {
    const auto at = static_cast<std::size_t>(c);
    return {nodes.data() + node_start[at], static_cast<std::size_t>(node_start[at + 1] - node_start[at])};
  }
  std::span<const int> children_of(int c) const {
    const auto at = static_cast<std::size_t>(c);
    return {children.data() + child_start[at], static_cast<std::size_t>(child_start[at + 1] - child_start[at])};
  }
};

// Nodes of a tree split for `parts` workers: each subtree list (ascending) is closed under
// descendants; `top` (ascending) holds every other node, each an ancestor of subtree roots.
struct EliminationSchedule {
  std::vector<std::vector<int>> subtrees;
  std::vector<int> top;
  TopChains top_chains;
};

// What a split of the tree aims for.
enum class SplitGoal {
  // The factorization: subtrees small enough to pack evenly (a sixteenth of a worker's share),
  // the top taking at most a quarter of the work. Its supernodes near the root hold most of the
  // arithmetic, and the blocked kernels there use every thread.
  EvenPacking,
  // The solve's sweeps: the least span, the top's work (on one thread, as the sweeps run most of
  // it) plus the busiest worker's. An entry of L costs a sweep the same wherever it lies, so the
  // even packing's top held a third of the Buddha's sweeps, most of it on one thread.
  LeastSpan,
};

// parent[j]: j's parent in the tree (parent[j] > j), −1 for a root; work[j]: the cost of node j.
EliminationSchedule split_elimination_tree(std::span<const int> parent, std::span<const double> work, int parts,
                                           SplitGoal goal = SplitGoal::EvenPacking);

// Runs `body(workspace, node)` for every node of a schedule: the subtrees concurrently (one
// workspace each, nodes ascending), then the top nodes ascending on the calling thread with the
// first workspace. `stop` ends the work early (checked between nodes).
template <class Workspace, class Body>
void for_each_node(const EliminationSchedule& schedule, std::vector<Workspace>& workspaces, const std::atomic<bool>& stop, Body&& body) {
  tbb::parallel_for(
      std::size_t{0}, schedule.subtrees.size(),
      [&](std::size_t part) {
        for (const int node : schedule.subtrees[part]) {
          if (stop.load(std::memory_order_relaxed)) return;
          body(workspaces[part], node);
        }
      },
      tbb::static_partitioner());
  for (const int node : schedule.top) {
    if (stop.load(std::memory_order_relaxed)) return;
    body(workspaces[0], node);
  }
}

// Supernodes of L: supernode s holds columns [first_column[s], first_column[s+1]), and its rows
// are those of its first column: FactorPattern::rows from rows_at[s] to rows_at[s+1], diagonal
// first.
struct Supernodes {
  std::vector<int> first_column;
  std::vector<int> of_column;  // the supernode of each column
  std::vector<std::size_t> rows_at;
  // The updates supernode s receives, ascending by the supernode d that gives them: rows
  // [first, last) of d's rows (counted from d's first column's diagonal) fall in s's columns.
  struct Update {
    int from;
    int first;
    int last;
  };
  std::vector<std::size_t> update_start;  // s's updates: [update_start[s], update_start[s+1])
  std::vector<Update> updates;
  // Where s's row i starts in the row layout's values: row_position[rows_at[s] + i] (its entries
  // in s's columns follow there).
  std::vector<int> row_position;
  EliminationSchedule schedule;  // over supernodes, weighted by their arithmetic
  std::size_t largest_panel = 0;  // rows × columns of the largest supernode

  int count() const { return static_cast<int>(first_column.size()) - 1; }
  int width(int s) const { return first_column[static_cast<std::size_t>(s) + 1] - first_column[static_cast<std::size_t>(s)]; }
};

// The pattern of L in the two layouts the solve sweeps read, and the trees that order them. A
// supernode's columns share its row list, so the column layout keeps no row index per entry.
// (Rows keep a column per entry: a row's columns come in runs of a supernode's consecutive
// columns, but runs average under four entries on a surface mesh, and a sweep over runs was
// measured 1.7 times slower than one over indices.)
struct FactorPattern {
  // L by rows (the forward sweep): row k is [row_start[k], row_start[k+1]), columns ascending,
  // diagonal last.
  std::vector<int> row_start;
  UninitializedVector<int> row_column;
  // L by columns (the backward sweep), the columns stored last to first so that the sweep streams
  // forwards: column j's values are [column_begin[j], column_end[j]), rows ascending, diagonal
  // first, and its rows are rows[rows_of_column[j]] on (the end of its supernode's row list).
  std::vector<std::size_t> column_begin;
  std::vector<std::size_t> column_end;
  std::vector<std::size_t> rows_of_column;
  UninitializedVector<int> rows;
  std::vector<int> parent;
  EliminationSchedule schedule;  // for the solve sweeps (schedule_sweeps)
  Supernodes supernodes;         // for the factorization (empty when another backend computed L)

  int size() const { return static_cast<int>(parent.size()); }
  std::size_t nonzeros() const { return row_start.empty() ? 0 : static_cast<std::size_t>(row_start.back()); }
  std::size_t column_length(int j) const {
    return column_end[static_cast<std::size_t>(j)] - column_begin[static_cast<std::size_t>(j)];
  }
  const int* column_rows(int j) const { return rows.data() + rows_of_column[static_cast<std::size_t>(j)]; }
};

// P A Pᵀ by columns, both triangles, rows ascending, for A symmetric with both triangles stored
// and factor_row[i] the row of unknown i: what the analysis and the numeric factorization read.
// Column k's entries above the diagonal are [start[k], diagonal[k]), the diagonal and below
// [diagonal[k], start[k+1]).
struct PermutedMatrix {
  std::vector<int> start;
  std::vector<int> diagonal;
  UninitializedVector<int> row;
  UninitializedVector<double> value;
};
PermutedMatrix permuted_matrix(const Eigen::SparseMatrix<double>& matrix, std::span<const int> factor_row);

// Updates of at least this many multiply-adds go through a blocked matrix product, and panels at
// least this wide through a blocked Cholesky factorization and triangular solve (the top of the
// tree); smaller ones through plain loops. The choice depends on the sizes alone, so each
// supernode's arithmetic is the same on any schedule.
inline constexpr long kBlockedUpdateWork = 32 * 1024;
inline constexpr int kBlockedPanelWidth = 32;

// Elimination tree, supernodes, the pattern of L in both layouts and their splits for `parts`
// workers.
FactorPattern analyse_pattern(const PermutedMatrix& matrix, int parts);

// pattern.schedule for `parts` workers, from the pattern's rows, columns and tree: each node costs
// its row (the forward sweep) and its column (the backward sweep).
void schedule_sweeps(FactorPattern& pattern, int parts);

// L's values in both layouts of `pattern` (row_value by rows, column_value by stored columns).
// Returns false when the matrix is not positive definite. The row layout may be float, for a
// factor kept in single precision: rows are only written while factoring, whereas the columns are
// read back by the updates and stay double (a factor computed from single-precision columns needed
// 17 correction steps for an exact 3.3M-triangle drag's 6 solves where this needs 11, and lowered
// the peak memory no further).
template <class RowValue>
bool factor_numeric(const PermutedMatrix& matrix, const FactorPattern& pattern, UninitializedVector<RowValue>& row_value,
                    UninitializedVector<double>& column_value);

}  // namespace hdeform::detail

#include "tree_factorization.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <limits>
#include <numeric>
#include <utility>


namespace hdeform::detail {
namespace {

// The elimination tree (Liu's algorithm with path compression), from the entries above the
// diagonal.
std::vector<int> elimination_tree(const PermutedMatrix& matrix) {
  const int n = static_cast<int>(matrix.start.size()) - 1;
  std::vector<int> parent(static_cast<std::size_t>(n), -1);
  std::vector<int> ancestor(static_cast<std::size_t>(n), -1);
  for (int k = 0; k < n; ++k) {
    for (int p = matrix.start[static_cast<std::size_t>(k)]; p < matrix.diagonal[static_cast<std::size_t>(k)]; ++p) {
      for (int i = matrix.row[static_cast<std::size_t>(p)]; i != -1 && i < k;) {
        const int next = ancestor[static_cast<std::size_t>(i)];
        ancestor[static_cast<std::size_t>(i)] = k;
        if (next == -1) parent[static_cast<std::size_t>(i)] = k;
        i = next;
      }
    }
  }
  return parent;
}

// Children of every node of a tree (parent[j] > j or −1), ascending: node p's children are
// children[child_start[p] .. child_start[p+1]).
struct Children {
  std::vector<int> child_start;
  std::vector<int> children;
};
Children children_of(std::span<const int> parent) {
  const std::size_t n = parent.size();
  Children tree;
  tree.child_start.assign(n + 1, 0);
  for (const int p : parent) {
    if (p >= 0) ++tree.child_start[static_cast<std::size_t>(p) + 1];
  }
  for (std::size_t j = 0; j < n; ++j) tree.child_start[j + 1] += tree.child_start[j];
  tree.children.resize(static_cast<std::size_t>(tree.child_start[n]));
  std::vector<int> fill(tree.child_start.begin(), tree.child_start.end() - 1);
  for (std::size_t j = 0; j < n; ++j) {
    if (const int p = parent[j]; p >= 0) tree.children[static_cast<std::size_t>(fill[static_cast<std::size_t>(p)]++)] = static_cast<int>(j);
  }
  return tree;
}

// The nodes of a tree in postorder (children in ascending order before their parent).
std::vector<int> postorder(std::span<const int> parent) {
  const Children tree = children_of(parent);
  std::vector<int> order;
  order.reserve(parent.size());
  std::vector<std::pair<int, int>> stack;  // node, next child to visit
  for (std::size_t root = 0; root < parent.size(); ++root) {
    if (parent[root] >= 0) continue;
    stack.emplace_back(static_cast<int>(root), tree.child_start[root]);
    while (!stack.empty()) {
      auto& [node, next] = stack.back();
      if (next < tree.child_start[static_cast<std::size_t>(node) + 1]) {
        const int child = tree.children[static_cast<std::size_t>(next++)];
        stack.emplace_back(child, tree.child_start[static_cast<std::size_t>(child)]);
      } else {
        order.push_back(node);
        stack.pop_back();
      }
    }
  }
  return order;
}

// The number of entries in each column of L, diagonal included, in near-linear time in the
// entries of the matrix (Gilbert, Ng and Peyton 1994, as in Davis's CSparse): column j's count
// is the number of row subtrees it lies in, counted with the skeleton of the matrix and the
// least common ancestors of consecutive leaves of each row subtree.
std::vector<int> column_counts(const PermutedMatrix& matrix, std::span<const int> parent) {
  const std::size_t n = parent.size();
  const std::vector<int> post = postorder(parent);
  std::vector<int> delta(n), first(n, -1), max_first(n, -1), previous_leaf(n, -1), ancestor(n);
  for (std::size_t k = 0; k < n; ++k) {
    int j = post[k];
    delta[static_cast<std::size_t>(j)] = first[static_cast<std::size_t>(j)] == -1 ? 1 : 0;  // 1 for a leaf
    for (; j != -1 && first[static_cast<std::size_t>(j)] == -1; j = parent[static_cast<std::size_t>(j)]) {
      first[static_cast<std::size_t>(j)] = static_cast<int>(k);
    }
  }
  std::iota(ancestor.begin(), ancestor.end(), 0);
  for (std::size_t k = 0; k < n; ++k) {
    const int j = post[k];
    const auto column = static_cast<std::size_t>(j);
    if (parent[column] != -1) --delta[static_cast<std::size_t>(parent[column])];
    // Row subtrees of the rows i > j with an entry in column j: is j a leaf of i's, and where
    // does it meet the previous leaf?
    for (int p = matrix.diagonal[column] + 1; p < matrix.start[column + 1]; ++p) {
      const auto i = static_cast<std::size_t>(matrix.row[static_cast<std::size_t>(p)]);
      if (first[column] <= max_first[i]) continue;  // j is not a leaf of row i's subtree
      max_first[i] = first[column];
      const int previous = previous_leaf[i];
      previous_leaf[i] = j;
      ++delta[column];
      if (previous == -1) continue;
      int q = previous;
      while (q != ancestor[static_cast<std::size_t>(q)]) q = ancestor[static_cast<std::size_t>(q)];
      for (int node = previous; node != q;) {
        const int next = ancestor[static_cast<std::size_t>(node)];
        ancestor[static_cast<std::size_t>(node)] = q;
        node = next;
      }
      --delta[static_cast<std::size_t>(q)];  // the overlap of the two leaves' paths
    }
    if (parent[column] != -1) ancestor[column] = parent[column];
  }
  for (std::size_t j = 0; j < n; ++j) {
    if (parent[j] != -1) delta[static_cast<std::size_t>(parent[j])] += delta[j];
  }
  return delta;
}

// The chains of the top (ascending node lists, closed under ancestors): a chain starts at a node
// with no top child or several, and climbs while the parent has the one top child it came from.
// Chains are numbered by their first node, so every chain comes after the chains below it.
TopChains top_chains(std::span<const int> parent, std::span<const double> work, std::span<const int> top) {
  std::vector<int> top_children(parent.size(), 0);
  for (const int node : top) {
    if (const int p = parent[static_cast<std::size_t>(node)]; p >= 0) ++top_children[static_cast<std::size_t>(p)];
  }
  TopChains chains;
  chains.nodes.reserve(top.size());
  chains.node_start.push_back(0);
  std::vector<int> chain_of(parent.size(), -1);
  for (const int first : top) {
    if (top_children[static_cast<std::size_t>(first)] == 1) continue;
    const int chain = chains.count();
    double chain_work = 0.0;
    for (int node = first;;) {
      chains.nodes.push_back(node);
      chain_of[static_cast<std::size_t>(node)] = chain;
      chain_work += work[static_cast<std::size_t>(node)];
      const int p = parent[static_cast<std::size_t>(node)];
      if (p < 0 || top_children[static_cast<std::size_t>(p)] != 1) break;
      node = p;
    }
    chains.node_start.push_back(static_cast<int>(chains.nodes.size()));
    chains.work.push_back(chain_work);
  }
  const auto count = static_cast<std::size_t>(chains.count());
  std::vector<int> chain_parent(count, -1);
  for (std::size_t c = 0; c < count; ++c) {
    const int last = chains.nodes[static_cast<std::size_t>(chains.node_start[c + 1]) - 1];
    if (const int p = parent[static_cast<std::size_t>(last)]; p >= 0) {
      chain_parent[c] = chain_of[static_cast<std::size_t>(p)];
      chains.work[static_cast<std::size_t>(chain_parent[c])] += chains.work[c];  // children come first
    } else {
      chains.roots.push_back(static_cast<int>(c));
    }
  }
  // The chains form a tree of their own, numbered children first.
  Children tree = children_of(chain_parent);
  chains.child_start = std::move(tree.child_start);
  chains.children = std::move(tree.children);
  return chains;
}

// Subtrees (work, root) packed largest first onto the least loaded of `parts` workers, ties by
// root so that the packing is deterministic: calls assign(root, worker) for each and returns the
// busiest worker's load. Sorts `subtrees`.
template <class Assign>
double pack_largest_first(std::vector<std::pair<double, int>>& subtrees, int parts, Assign&& assign) {
  std::sort(subtrees.begin(), subtrees.end(), [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
  std::vector<double> load(static_cast<std::size_t>(parts), 0.0);
  for (const auto& [subtree, root] : subtrees) {
    const auto worker = static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[worker] += subtree;
    assign(root, static_cast<int>(worker));
  }
  return *std::max_element(load.begin(), load.end());
}

}  // namespace

EliminationSchedule split_elimination_tree(std::span<const int> parent, std::span<const double> work, int parts, SplitGoal goal) {
  EliminationSchedule schedule;
  const int n = static_cast<int>(parent.size());
  if (parts <= 1 || n < 1024) {
    schedule.top.resize(static_cast<std::size_t>(n));
    std::iota(schedule.top.begin(), schedule.top.end(), 0);
    schedule.top_chains = top_chains(parent, work, schedule.top);
    return schedule;
  }
  std::vector<double> subtree_work(work.begin(), work.end());
  double total = 0.0;
  for (int j = 0; j < n; ++j) {
    total += work[static_cast<std::size_t>(j)];
    if (const int p = parent[static_cast<std::size_t>(j)]; p >= 0) subtree_work[static_cast<std::size_t>(p)] += subtree_work[static_cast<std::size_t>(j)];
  }
  const Children tree = children_of(parent);

  // Both goals take the largest subtree's root into the top, one root at a time, and differ in
  // where they stop. EvenPacking: once every subtree is small enough for an even packing onto the
  // workers. LeastSpan: at the count of roots taken that gave the least span, looking on while a
  // larger top could still give less (its span is at least the top's work plus an even share of
  // the rest, which grows with the top).
  const double grain = total / (16.0 * parts);
  const double top_limit = 0.25 * total;
  std::vector<std::pair<double, int>> heap;
  for (int j = 0; j < n; ++j) {
    if (parent[static_cast<std::size_t>(j)] < 0) heap.emplace_back(subtree_work[static_cast<std::size_t>(j)], j);
  }
  std::make_heap(heap.begin(), heap.end());
  std::vector<int> taken;
  double top_work = 0.0;
  std::size_t best_count = 0;
  double best_span = std::numeric_limits<double>::infinity();
  std::vector<std::pair<double, int>> packing;
  bool branched = true;
  while (!heap.empty()) {
    if (goal == SplitGoal::EvenPacking) {
      if (heap.front().first <= grain || top_work >= top_limit) break;
    } else {
      if (branched) {
        packing.assign(heap.begin(), heap.end());
        if (const double span = top_work + pack_largest_first(packing, parts, [](int, int) {}); span < best_span) {
          best_span = span;
          best_count = taken.size();
        }
      }
      if (top_work + (total - top_work) / parts >= best_span) break;
    }
    std::pop_heap(heap.begin(), heap.end());
    const int root = heap.back().second;
    heap.pop_back();
    taken.push_back(root);
    top_work += work[static_cast<std::size_t>(root)];
    // A root with one child hands its subtree on less itself: the top grows by what the packing
    // could lose at most, so only tops that end where the tree branches (or at a leaf) are packed.
    branched = tree.child_start[static_cast<std::size_t>(root) + 1] - tree.child_start[static_cast<std::size_t>(root)] != 1;
    for (int c = tree.child_start[static_cast<std::size_t>(root)]; c < tree.child_start[static_cast<std::size_t>(root) + 1]; ++c) {
      const int child = tree.children[static_cast<std::size_t>(c)];
      heap.emplace_back(subtree_work[static_cast<std::size_t>(child)], child);
      std::push_heap(heap.begin(), heap.end());
    }
  }
  if (goal == SplitGoal::EvenPacking) best_count = taken.size();
  taken.resize(best_count);
  schedule.top = taken;
  std::vector<char> in_top(static_cast<std::size_t>(n), 0);
  for (const int node : schedule.top) in_top[static_cast<std::size_t>(node)] = 1;
  // The subtrees left: every node outside the top whose parent is in it, and the roots outside it.
  std::vector<std::pair<double, int>> subtrees;
  for (int j = 0; j < n; ++j) {
    const int p = parent[static_cast<std::size_t>(j)];
    if (in_top[static_cast<std::size_t>(j)] == 0 && (p < 0 || in_top[static_cast<std::size_t>(p)] != 0)) subtrees.emplace_back(subtree_work[static_cast<std::size_t>(j)], j);
  }
  // Every node's worker (−1: the top), then each worker's nodes in ascending order: a node's
  // parent comes after it, so a node takes its parent's worker unless it is a subtree's root.
  std::vector<int> worker_of(static_cast<std::size_t>(n), -1);
  std::vector<std::size_t> counts(static_cast<std::size_t>(parts), 0);
  pack_largest_first(subtrees, parts, [&](int root, int worker) { worker_of[static_cast<std::size_t>(root)] = worker; });
  for (int j = n; j-- > 0;) {
    const auto node = static_cast<std::size_t>(j);
    if (in_top[node] != 0) continue;
    if (worker_of[node] < 0) worker_of[node] = worker_of[static_cast<std::size_t>(parent[node])];
    ++counts[static_cast<std::size_t>(worker_of[node])];
  }
  schedule.subtrees.assign(static_cast<std::size_t>(parts), {});
  for (int worker = 0; worker < parts; ++worker) schedule.subtrees[static_cast<std::size_t>(worker)].reserve(counts[static_cast<std::size_t>(worker)]);
  for (int j = 0; j < n; ++j) {
    if (in_top[static_cast<std::size_t>(j)] == 0) schedule.subtrees[static_cast<std::size_t>(worker_of[static_cast<std::size_t>(j)])].push_back(j);
  }
  std::sort(schedule.top.begin(), schedule.top.end());
  schedule.top_chains = top_chains(parent, work, schedule.top);
  return schedule;
}

PermutedMatrix permuted_matrix(const Eigen::SparseMatrix<double>& matrix, std::span<const int> factor_row) {
  const auto n = static_cast<std::size_t>(matrix.cols());
  const int* outer = matrix.outerIndexPtr();
  const int* inner = matrix.innerIndexPtr();
  const double* value = matrix.valuePtr();
  const int* nonzeros = matrix.innerNonZeroPtr();  // null when compressed
  auto column_end = [&](std::size_t c) { return nonzeros != nullptr ? outer[c] + nonzeros[c] : outer[c + 1]; };
  PermutedMatrix permuted;
  permuted.start.assign(n + 1, 0);
  permuted.diagonal.resize(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t c) {
    permuted.start[static_cast<std::size_t>(factor_row[c]) + 1] = column_end(c) - outer[c];
  });
  for (std::size_t k = 0; k < n; ++k) permuted.start[k + 1] += permuted.start[k];
  permuted.row.resize(static_cast<std::size_t>(permuted.start[n]));
  permuted.value.resize(permuted.row.size());
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t c) {
    const auto k = static_cast<std::size_t>(factor_row[c]);
    const auto first = static_cast<std::size_t>(permuted.start[k]);
    std::size_t next = first;
    for (int p = outer[c]; p < column_end(c); ++p, ++next) {
      permuted.row[next] = factor_row[static_cast<std::size_t>(inner[p])];
      permuted.value[next] = value[p];
    }
    // Insertion sort by row: a column holds a handful of entries.
    for (std::size_t a = first + 1; a < next; ++a) {
      for (std::size_t b = a; b > first && permuted.row[b - 1] > permuted.row[b]; --b) {
        std::swap(permuted.row[b - 1], permuted.row[b]);
        std::swap(permuted.value[b - 1], permuted.value[b]);
      }
    }
    std::size_t diagonal = first;
    while (diagonal < next && permuted.row[diagonal] < static_cast<int>(k)) ++diagonal;
    permuted.diagonal[k] = static_cast<int>(diagonal);
  });
  return permuted;
}

FactorPattern analyse_pattern(const PermutedMatrix& matrix, int parts) {
  FactorPattern pattern;
  const int n = static_cast<int>(matrix.start.size()) - 1;
  const auto size = static_cast<std::size_t>(n);
  pattern.parent = elimination_tree(matrix);
  const std::atomic<bool> never{false};

  const std::vector<int> column_count = column_counts(matrix, pattern.parent);
  // Supernodes: column j joins column j−1's when j−1's rows below its diagonal are j's rows and j.
  Supernodes& super = pattern.supernodes;
  super.first_column.push_back(0);
  for (int j = 1; j < n; ++j) {
    const auto column = static_cast<std::size_t>(j);
    if (pattern.parent[column - 1] != j || column_count[column - 1] != column_count[column] + 1) super.first_column.push_back(j);
  }
  super.first_column.push_back(n);
  if (n == 0) super.first_column.assign(1, 0);
  const int supernode_count = super.count();
  super.of_column.resize(size);
  std::vector<int> super_parent(static_cast<std::size_t>(supernode_count), -1);
  std::vector<double> super_work(static_cast<std::size_t>(supernode_count), 0.0);
  for (int s = 0; s < supernode_count; ++s) {
    const int first = super.first_column[static_cast<std::size_t>(s)], end = super.first_column[static_cast<std::size_t>(s) + 1];
    const double rows = column_count[static_cast<std::size_t>(first)];
    double work = 0.0;
    for (int j = first; j < end; ++j) {
      super.of_column[static_cast<std::size_t>(j)] = s;
      const double length = rows - (j - first);
      work += 0.5 * length * length;  // the updates column j gives and its own division
    }
    super_work[static_cast<std::size_t>(s)] = work;
    super.largest_panel = std::max(super.largest_panel, static_cast<std::size_t>(rows) * static_cast<std::size_t>(end - first));
  }
  for (int s = 0; s < supernode_count; ++s) {
    const int last = super.first_column[static_cast<std::size_t>(s) + 1] - 1;
    if (const int p = pattern.parent[static_cast<std::size_t>(last)]; p >= 0) super_parent[static_cast<std::size_t>(s)] = super.of_column[static_cast<std::size_t>(p)];
  }
  super.schedule = split_elimination_tree(super_parent, super_work, parts);

  // The column layout, columns stored last to first, and where each supernode's rows go.
  pattern.column_begin.resize(size);
  pattern.column_end.resize(size);
  for (std::size_t j = size, next = 0; j-- > 0;) {
    pattern.column_begin[j] = next;
    next += static_cast<std::size_t>(column_count[j]);
    pattern.column_end[j] = next;
  }
  super.rows_at.assign(static_cast<std::size_t>(supernode_count) + 1, 0);
  pattern.rows_of_column.resize(size);
  for (int s = 0; s < supernode_count; ++s) {
    const auto at = super.rows_at[static_cast<std::size_t>(s)];
    const int first = super.first_column[static_cast<std::size_t>(s)];
    for (int j = first; j < super.first_column[static_cast<std::size_t>(s) + 1]; ++j) pattern.rows_of_column[static_cast<std::size_t>(j)] = at + static_cast<std::size_t>(j - first);
    super.rows_at[static_cast<std::size_t>(s) + 1] = at + static_cast<std::size_t>(column_count[static_cast<std::size_t>(first)]);
  }
  pattern.rows.resize(super.rows_at.back());
  auto rows_of = [&](int s) { return pattern.rows.data() + super.rows_at[static_cast<std::size_t>(s)]; };
  auto row_count_of = [&](int s) { return static_cast<int>(super.rows_at[static_cast<std::size_t>(s) + 1] - super.rows_at[static_cast<std::size_t>(s)]); };

  // Each supernode's rows: its own columns, then the rows below them of its columns in the matrix
  // and of its children's rows, sorted. Children come first in every part of the schedule.
  {
    const Children tree = children_of(super_parent);
    struct Gather {
      std::vector<int> mark;
      std::vector<int> below;
    };
    std::vector<Gather> gathers(std::max<std::size_t>(1, super.schedule.subtrees.size()));
    for (auto& g : gathers) g.mark.assign(size, -1);
    for_each_node(super.schedule, gathers, never, [&](Gather& g, int s) {
      const auto node = static_cast<std::size_t>(s);
      const int first = super.first_column[node], end = super.first_column[node + 1];
      g.below.clear();
      auto add = [&](int row) {
        if (row >= end && g.mark[static_cast<std::size_t>(row)] != s) {
          g.mark[static_cast<std::size_t>(row)] = s;
          g.below.push_back(row);
        }
      };
      for (int j = first; j < end; ++j) {
        for (int p = matrix.diagonal[static_cast<std::size_t>(j)]; p < matrix.start[static_cast<std::size_t>(j) + 1]; ++p) add(matrix.row[static_cast<std::size_t>(p)]);
      }
      for (int c = tree.child_start[node]; c < tree.child_start[node + 1]; ++c) {
        const int child = tree.children[static_cast<std::size_t>(c)];
        const int* child_rows = rows_of(child);
        for (int i = super.width(child), m = row_count_of(child); i < m; ++i) add(child_rows[i]);
      }
      // Runs of ascending rows, one per child and column: a short list is nearly sorted.
      if (g.below.size() <= 64) {
        for (std::size_t a = 1; a < g.below.size(); ++a) {
          const int row = g.below[a];
          std::size_t b = a;
          for (; b > 0 && g.below[b - 1] > row; --b) g.below[b] = g.below[b - 1];
          g.below[b] = row;
        }
      } else {
        std::sort(g.below.begin(), g.below.end());
      }
      int* rows = rows_of(s);
      std::iota(rows, rows + (end - first), first);
      std::copy(g.below.begin(), g.below.end(), rows + (end - first));
    });
  }

  // The row layout: row k holds, for every supernode s whose rows include k (ascending), s's
  // columns up to k. Where each supernode row's entries start is kept for the factorization.
  pattern.row_start.assign(size + 1, 0);
  for (int s = 0; s < supernode_count; ++s) {
    const int width = super.width(s);
    const int* rows = rows_of(s);
    for (int i = 0, m = row_count_of(s); i < m; ++i) pattern.row_start[static_cast<std::size_t>(rows[i]) + 1] += std::min(i + 1, width);
  }
  for (std::size_t k = 0; k < size; ++k) pattern.row_start[k + 1] += pattern.row_start[k];
  super.row_position.resize(pattern.rows.size());
  {
    std::vector<int> at(pattern.row_start.begin(), pattern.row_start.end() - 1);
    for (int s = 0; s < supernode_count; ++s) {
      const int width = super.width(s);
      const int* rows = rows_of(s);
      int* position = super.row_position.data() + super.rows_at[static_cast<std::size_t>(s)];
      for (int i = 0, m = row_count_of(s); i < m; ++i) {
        position[i] = at[static_cast<std::size_t>(rows[i])];
        at[static_cast<std::size_t>(rows[i])] += std::min(i + 1, width);
      }
    }
  }
  pattern.row_column.resize(static_cast<std::size_t>(pattern.row_start.back()));
  tbb::parallel_for(tbb::blocked_range<int>(0, supernode_count, 256), [&](const tbb::blocked_range<int>& range) {
    for (int s = range.begin(); s != range.end(); ++s) {
      const int first = super.first_column[static_cast<std::size_t>(s)];
      const int width = super.width(s);
      const int* position = super.row_position.data() + super.rows_at[static_cast<std::size_t>(s)];
      for (int i = 0, m = row_count_of(s); i < m; ++i) {
        int* columns = pattern.row_column.data() + position[i];
        std::iota(columns, columns + std::min(i + 1, width), first);
      }
    }
  });

  // The updates each supernode receives: every earlier supernode d with rows in its columns, the
  // run of d's rows that falls there. Found per block of d in parallel, then gathered per target
  // in block order, so that each target's updates come in ascending d.
  {
    constexpr int kBlock = 1024;
    const int blocks = (supernode_count + kBlock - 1) / kBlock;
    std::vector<std::vector<std::pair<int, Supernodes::Update>>> found(static_cast<std::size_t>(blocks));
    tbb::parallel_for(0, blocks, [&](int block) {
      auto& list = found[static_cast<std::size_t>(block)];
      for (int d = block * kBlock, end = std::min(supernode_count, d + kBlock); d < end; ++d) {
        const int* rows = rows_of(d);
        const int m = row_count_of(d);
        for (int i = super.width(d); i < m;) {
          const int target = super.of_column[static_cast<std::size_t>(rows[i])];
          const int run_end = super.first_column[static_cast<std::size_t>(target) + 1];
          int last = i + 1;
          while (last < m && rows[last] < run_end) ++last;
          list.emplace_back(target, Supernodes::Update{d, i, last});
          i = last;
        }
      }
    });
    super.update_start.assign(static_cast<std::size_t>(supernode_count) + 1, 0);
    for (const auto& list : found) {
      for (const auto& entry : list) ++super.update_start[static_cast<std::size_t>(entry.first) + 1];
    }
    for (int s = 0; s < supernode_count; ++s) super.update_start[static_cast<std::size_t>(s) + 1] += super.update_start[static_cast<std::size_t>(s)];
    super.updates.resize(super.update_start.back());
    std::vector<std::size_t> fill(super.update_start.begin(), super.update_start.end() - 1);
    for (const auto& list : found) {
      for (const auto& [target, update] : list) super.updates[fill[static_cast<std::size_t>(target)]++] = update;
    }
  }

  schedule_sweeps(pattern, parts);
  return pattern;
}

void schedule_sweeps(FactorPattern& pattern, int parts) {
  const auto size = static_cast<std::size_t>(pattern.size());
  std::vector<double> work(size);
  for (std::size_t j = 0; j < size; ++j) {
    work[j] = static_cast<double>(pattern.row_start[j + 1] - pattern.row_start[j]) + static_cast<double>(pattern.column_length(static_cast<int>(j)));
  }
  pattern.schedule = split_elimination_tree(pattern.parent, work, parts, SplitGoal::LeastSpan);
}

}  // namespace hdeform::detail

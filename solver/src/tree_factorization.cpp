#include "tree_factorization.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <utility>

namespace hdeform::detail {
namespace {

// Runs `row_body(workspace, k)` for every row of a schedule: the subtrees concurrently (one
// workspace each, rows ascending), then the top rows ascending on the calling thread with the
// first workspace. `stop` ends the work early (checked between rows).
template <class Workspace, class RowBody>
void for_each_row(const EliminationSchedule& schedule, std::vector<Workspace>& workspaces, const std::atomic<bool>& stop,
                  RowBody&& row_body) {
  tbb::parallel_for(
      std::size_t{0}, schedule.subtrees.size(),
      [&](std::size_t part) {
        for (const int k : schedule.subtrees[part]) {
          if (stop.load(std::memory_order_relaxed)) return;
          row_body(workspaces[part], k);
        }
      },
      tbb::static_partitioner());
  for (const int k : schedule.top) {
    if (stop.load(std::memory_order_relaxed)) return;
    row_body(workspaces[0], k);
  }
}

// The elimination tree of the upper triangle (Liu's algorithm with path compression).
std::vector<int> elimination_tree(const PermutedUpper& upper) {
  const int n = static_cast<int>(upper.start.size()) - 1;
  std::vector<int> parent(static_cast<std::size_t>(n), -1);
  std::vector<int> ancestor(static_cast<std::size_t>(n), -1);
  for (int k = 0; k < n; ++k) {
    for (int p = upper.start[static_cast<std::size_t>(k)]; p < upper.start[static_cast<std::size_t>(k) + 1]; ++p) {
      for (int i = upper.row[static_cast<std::size_t>(p)]; i != -1 && i < k;) {
        const int next = ancestor[static_cast<std::size_t>(i)];
        ancestor[static_cast<std::size_t>(i)] = k;
        if (next == -1) parent[static_cast<std::size_t>(i)] = k;
        i = next;
      }
    }
  }
  return parent;
}

// Visits the pattern of row k of L below the diagonal (the etree paths from the entries of A's
// column k up to k), in no particular order. `mark` is a per-thread array, initially all −1.
template <class Visit>
void visit_row_pattern(const PermutedUpper& upper, const std::vector<int>& parent, int k, std::vector<int>& mark, Visit&& visit) {
  mark[static_cast<std::size_t>(k)] = k;
  for (int p = upper.start[static_cast<std::size_t>(k)]; p < upper.start[static_cast<std::size_t>(k) + 1]; ++p) {
    for (int i = upper.row[static_cast<std::size_t>(p)]; i < k && mark[static_cast<std::size_t>(i)] != k;
         i = parent[static_cast<std::size_t>(i)]) {
      mark[static_cast<std::size_t>(i)] = k;
      visit(i);
    }
  }
}

}  // namespace

EliminationSchedule split_elimination_tree(std::span<const int> parent, std::span<const double> work, int parts) {
  EliminationSchedule schedule;
  const int n = static_cast<int>(parent.size());
  if (parts <= 1 || n < 1024) {
    schedule.top.resize(static_cast<std::size_t>(n));
    std::iota(schedule.top.begin(), schedule.top.end(), 0);
    return schedule;
  }
  std::vector<double> subtree_work(work.begin(), work.end());
  std::vector<int> child_start(static_cast<std::size_t>(n) + 1, 0);
  double total = 0.0;
  for (int j = 0; j < n; ++j) {
    total += work[static_cast<std::size_t>(j)];
    if (const int p = parent[static_cast<std::size_t>(j)]; p >= 0) {
      subtree_work[static_cast<std::size_t>(p)] += subtree_work[static_cast<std::size_t>(j)];
      ++child_start[static_cast<std::size_t>(p) + 1];
    }
  }
  for (int j = 0; j < n; ++j) child_start[static_cast<std::size_t>(j) + 1] += child_start[static_cast<std::size_t>(j)];
  std::vector<int> children(static_cast<std::size_t>(child_start.back()));
  {
    std::vector<int> fill(child_start.begin(), child_start.end() - 1);
    for (int j = 0; j < n; ++j) {
      if (const int p = parent[static_cast<std::size_t>(j)]; p >= 0) children[static_cast<std::size_t>(fill[static_cast<std::size_t>(p)]++)] = j;
    }
  }

  // Proportional splitting: take the largest subtree's root into the top part until every
  // subtree is small enough for an even packing onto the workers.
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
    schedule.top.push_back(root);
    top_work += work[static_cast<std::size_t>(root)];
    for (int c = child_start[static_cast<std::size_t>(root)]; c < child_start[static_cast<std::size_t>(root) + 1]; ++c) {
      const int child = children[static_cast<std::size_t>(c)];
      heap.emplace_back(subtree_work[static_cast<std::size_t>(child)], child);
      std::push_heap(heap.begin(), heap.end());
    }
  }
  // Largest first onto the least loaded worker; ties by root index keep it deterministic.
  std::sort(heap.begin(), heap.end(), [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
  schedule.subtrees.assign(static_cast<std::size_t>(parts), {});
  std::vector<double> load(static_cast<std::size_t>(parts), 0.0);
  std::vector<int> stack;
  for (const auto& [subtree, root] : heap) {
    const auto worker = static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[worker] += subtree;
    stack.assign(1, root);
    while (!stack.empty()) {
      const int node = stack.back();
      stack.pop_back();
      schedule.subtrees[worker].push_back(node);
      for (int c = child_start[static_cast<std::size_t>(node)]; c < child_start[static_cast<std::size_t>(node) + 1]; ++c) {
        stack.push_back(children[static_cast<std::size_t>(c)]);
      }
    }
  }
  for (auto& subtree : schedule.subtrees) std::sort(subtree.begin(), subtree.end());
  std::sort(schedule.top.begin(), schedule.top.end());
  return schedule;
}

PermutedUpper permuted_upper(const Eigen::SparseMatrix<double>& matrix, std::span<const int> factor_row) {
  const auto n = static_cast<std::size_t>(matrix.cols());
  const int* outer = matrix.outerIndexPtr();
  const int* inner = matrix.innerIndexPtr();
  const double* value = matrix.valuePtr();
  const int* nonzeros = matrix.innerNonZeroPtr();  // null when compressed
  auto column_end = [&](std::size_t c) { return nonzeros != nullptr ? outer[c] + nonzeros[c] : outer[c + 1]; };
  PermutedUpper upper;
  upper.start.assign(n + 1, 0);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t c) {
    const int k = factor_row[c];
    int count = 0;
    for (int p = outer[c]; p < column_end(c); ++p) count += factor_row[static_cast<std::size_t>(inner[p])] <= k;
    upper.start[static_cast<std::size_t>(k) + 1] = count;
  });
  for (std::size_t k = 0; k < n; ++k) upper.start[k + 1] += upper.start[k];
  upper.row.resize(static_cast<std::size_t>(upper.start[n]));
  upper.value.resize(upper.row.size());
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t c) {
    const int k = factor_row[c];
    const auto first = static_cast<std::size_t>(upper.start[static_cast<std::size_t>(k)]);
    std::size_t next = first;
    for (int p = outer[c]; p < column_end(c); ++p) {
      const int r = factor_row[static_cast<std::size_t>(inner[p])];
      if (r <= k) {
        upper.row[next] = r;
        upper.value[next++] = value[p];
      }
    }
    // Insertion sort by row: a column holds a handful of entries.
    for (std::size_t a = first + 1; a < next; ++a) {
      for (std::size_t b = a; b > first && upper.row[b - 1] > upper.row[b]; --b) {
        std::swap(upper.row[b - 1], upper.row[b]);
        std::swap(upper.value[b - 1], upper.value[b]);
      }
    }
  });
  return upper;
}

FactorPattern analyse_pattern(const PermutedUpper& upper, int parts) {
  FactorPattern pattern;
  const int n = static_cast<int>(upper.start.size()) - 1;
  const auto size = static_cast<std::size_t>(n);
  pattern.parent = elimination_tree(upper);

  // Every row's pattern, walked once and sorted, in parallel over subtrees (a row's walk stays in
  // its subtree, so each column's count is touched by one worker at a time). Rows are weighed
  // alike here: their patterns' lengths are what the walk finds out.
  const std::vector<double> unit(size, 1.0);
  const EliminationSchedule walk_schedule = split_elimination_tree(pattern.parent, unit, parts);
  struct Walk {
    std::vector<int> mark;
    std::vector<int> columns;  // the sorted patterns of this worker's rows, one after the other
  };
  std::vector<Walk> walks(std::max<std::size_t>(1, walk_schedule.subtrees.size()));
  for (auto& w : walks) w.mark.assign(size, -1);
  std::vector<std::size_t> walked_at(size);  // where row k's pattern starts in its worker's list
  std::vector<int> walker(size);             // and which worker walked it
  std::vector<int> column_count(size, 1);
  pattern.row_start.assign(size + 1, 0);
  const std::atomic<bool> never{false};
  for_each_row(walk_schedule, walks, never, [&](Walk& w, int k) {
    const std::size_t first = w.columns.size();
    walked_at[static_cast<std::size_t>(k)] = first;
    walker[static_cast<std::size_t>(k)] = static_cast<int>(&w - walks.data());
    visit_row_pattern(upper, pattern.parent, k, w.mark, [&](int j) {
      w.columns.push_back(j);
      ++column_count[static_cast<std::size_t>(j)];
    });
    std::sort(w.columns.begin() + static_cast<std::ptrdiff_t>(first), w.columns.end());
    pattern.row_start[static_cast<std::size_t>(k) + 1] = static_cast<int>(w.columns.size() - first) + 1;
  });
  for (std::size_t k = 0; k < size; ++k) pattern.row_start[k + 1] += pattern.row_start[k];
  const auto nonzeros = static_cast<std::size_t>(pattern.row_start[size]);
  pattern.column_begin.resize(size);
  pattern.column_end.resize(size);
  for (std::size_t j = size, next = 0; j-- > 0;) {
    pattern.column_begin[j] = next;
    next += static_cast<std::size_t>(column_count[j]);
    pattern.column_end[j] = next;
  }
  // A solve's sweeps cost a row its column's length; the factorization's updates of column j
  // cost about its length squared over two (most of them in the separators near the root).
  {
    std::vector<double> work(column_count.begin(), column_count.end());
    pattern.schedule = split_elimination_tree(pattern.parent, work, parts);
    for (double& w : work) w = 0.5 * w * w;
    pattern.factor_schedule = split_elimination_tree(pattern.parent, work, parts);
  }

  // Both layouts' indices. Columns fill in ascending row order: a subtree's rows touch only its
  // own columns, and the top rows, which come after, are larger than every subtree row.
  pattern.row_column.resize(nonzeros);
  pattern.column_row.resize(nonzeros);
  std::vector<std::size_t> filled(pattern.column_begin);
  std::vector<char> unused(walks.size());
  for_each_row(walk_schedule, unused, never, [&](char&, int k) {
    const auto row = static_cast<std::size_t>(k);
    const auto first = static_cast<std::size_t>(pattern.row_start[row]);
    const auto diagonal = static_cast<std::size_t>(pattern.row_start[row + 1]) - 1;
    const int* walked = walks[static_cast<std::size_t>(walker[row])].columns.data() + walked_at[row];
    std::copy(walked, walked + (diagonal - first), pattern.row_column.begin() + static_cast<std::ptrdiff_t>(first));
    pattern.row_column[diagonal] = k;
    for (std::size_t q = first; q <= diagonal; ++q) pattern.column_row[filled[static_cast<std::size_t>(pattern.row_column[q])]++] = k;
  });
  return pattern;
}

constexpr std::size_t kPrefetchDistance = 8;

bool factor_numeric(const PermutedUpper& upper, const FactorPattern& pattern, std::vector<double>& row_value,
                    std::vector<double>& column_value) {
  const auto size = static_cast<std::size_t>(pattern.size());
  row_value.assign(pattern.nonzeros(), 0.0);
  column_value.assign(pattern.nonzeros(), 0.0);
  struct Workspace {
    std::vector<double> y;  // the row being solved, scattered; all zero between rows
  };
  std::vector<Workspace> workspaces(std::max<std::size_t>(1, pattern.factor_schedule.subtrees.size()));
  for (auto& w : workspaces) w.y.assign(size, 0.0);
  std::vector<std::size_t> filled(size, 0);  // entries of each column computed so far
  std::atomic<bool> failed{false};
  const int* row_column = pattern.row_column.data();
  const int* column_row = pattern.column_row.data();
  const std::size_t* column_begin = pattern.column_begin.data();
  for_each_row(pattern.factor_schedule, workspaces, failed, [&](Workspace& w, int k) {
    double* y = w.y.data();
    for (int p = upper.start[static_cast<std::size_t>(k)]; p < upper.start[static_cast<std::size_t>(k) + 1]; ++p) {
      y[upper.row[static_cast<std::size_t>(p)]] += upper.value[static_cast<std::size_t>(p)];
    }
    double d = y[k];
    y[k] = 0.0;
    const auto first = static_cast<std::size_t>(pattern.row_start[static_cast<std::size_t>(k)]);
    const auto diagonal = static_cast<std::size_t>(pattern.row_start[static_cast<std::size_t>(k) + 1]) - 1;
    // Ascending columns are a topological order: column j updates only rows between j and k.
    for (std::size_t q = first; q < diagonal; ++q) {
      // The columns a row reads are scattered over the factor: fetch the next ones' starts ahead
      // (the top rows read thousands of columns each, one cache miss or more per column).
      if (q + 2 * kPrefetchDistance < diagonal) {
        const auto ahead = static_cast<std::size_t>(row_column[q + 2 * kPrefetchDistance]);
        __builtin_prefetch(&column_begin[ahead]);
        __builtin_prefetch(&filled[ahead]);
      }
      if (q + kPrefetchDistance < diagonal) {
        const std::size_t ahead = column_begin[static_cast<std::size_t>(row_column[q + kPrefetchDistance])];
        __builtin_prefetch(&column_value[ahead]);
        __builtin_prefetch(&column_row[ahead + 1]);
      }
      const auto j = static_cast<std::size_t>(row_column[q]);
      const std::size_t begin = column_begin[j];
      const std::size_t end = begin + filled[j];
      const double l = y[j] / column_value[begin];
      y[j] = 0.0;
      for (std::size_t p = begin + 1; p < end; ++p) y[column_row[p]] -= column_value[p] * l;
      column_value[end] = l;
      ++filled[j];
      row_value[q] = l;
      d -= l * l;
    }
    if (!(d > 0.0)) {
      failed.store(true, std::memory_order_relaxed);
      return;
    }
    const double root = std::sqrt(d);
    column_value[column_begin[static_cast<std::size_t>(k)]] = root;
    filled[static_cast<std::size_t>(k)] = 1;
    row_value[diagonal] = root;
  });
  return !failed.load();
}

}  // namespace hdeform::detail

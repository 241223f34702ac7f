#include "edge_counts.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <vector>

namespace hdeform::detail {

EdgeCounts count_edges(const Eigen::MatrixXi& triangles, std::size_t vertex_count, bool self_edges, DisjointSets* components) {
  const Eigen::Index count = triangles.rows();
  auto each_edge = [&](auto&& visit) {
    for (Eigen::Index t = 0; t < count; ++t) {
      for (int k = 0; k < 3; ++k) {
        const int a = triangles(t, k), b = triangles(t, (k + 1) % 3);
        if (a != b || self_edges) visit(std::min(a, b), std::max(a, b));
      }
    }
  };
  // Each edge's higher vertex, bucketed by its lower one: an edge in m triangles appears m times.
  std::vector<std::size_t> start(vertex_count + 1, 0);
  each_edge([&](int low, int) { ++start[static_cast<std::size_t>(low) + 1]; });
  for (std::size_t v = 0; v < vertex_count; ++v) start[v + 1] += start[v];
  std::vector<int> high(start[vertex_count]);
  {
    std::vector<std::size_t> next(start.begin(), start.end() - 1);
    each_edge([&](int low, int other) { high[next[static_cast<std::size_t>(low)]++] = other; });
  }
  std::atomic<std::size_t> edges{0}, boundary{0}, nonmanifold{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertex_count, 4096), [&](const tbb::blocked_range<std::size_t>& range) {
    std::size_t local_edges = 0, local_boundary = 0, local_nonmanifold = 0;
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      const auto first = high.begin() + static_cast<std::ptrdiff_t>(start[v]);
      const auto last = high.begin() + static_cast<std::ptrdiff_t>(start[v + 1]);
      std::sort(first, last);
      for (auto run = first; run != last;) {
        const auto end = std::find_if(run, last, [&](int w) { return w != *run; });
        ++local_edges;
        local_boundary += end - run == 1 ? 1 : 0;
        local_nonmanifold += end - run > 2 ? 1 : 0;
        run = end;
      }
    }
    edges += local_edges;
    boundary += local_boundary;
    nonmanifold += local_nonmanifold;
  });
  if (components != nullptr) {
    for (std::size_t v = 0; v < vertex_count; ++v) {
      for (std::size_t i = start[v]; i < start[v + 1]; ++i) {
        if (high[i] != static_cast<int>(v) && (i == start[v] || high[i] != high[i - 1])) components->unite(static_cast<int>(v), high[i]);
      }
    }
  }
  return {edges.load(), boundary.load(), nonmanifold.load()};
}

}  // namespace hdeform::detail

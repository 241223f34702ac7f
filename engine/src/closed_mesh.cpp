#include "hdeform/engine/closed_mesh.h"

#include <algorithm>
#include <vector>

namespace hdeform::engine {

bool every_edge_has_its_reverse(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count) {
  if (triangles.rows() == 0) return false;
  // Each directed edge's far end, bucketed by its near end (a counting sort: sorting the 10
  // million edges of a 3.3M-triangle scan held its first frame for a second), each bucket sorted,
  // then each edge's reverse looked up in its far end's bucket.
  const auto n = static_cast<std::size_t>(vertex_count);
  std::vector<int> start(n + 1, 0);
  auto each_edge = [&](auto&& visit) {
    for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
      for (int k = 0; k < 3; ++k) visit(triangles(t, k), triangles(t, (k + 1) % 3));
    }
  };
  each_edge([&](int from, int) { ++start[static_cast<std::size_t>(from) + 1]; });
  for (std::size_t v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<int> next(start.begin(), start.end() - 1);
  std::vector<int> to(static_cast<std::size_t>(start[n]));
  each_edge([&](int from, int far) { to[static_cast<std::size_t>(next[static_cast<std::size_t>(from)]++)] = far; });
  auto bucket = [&](int v) { return std::pair{to.begin() + start[static_cast<std::size_t>(v)], to.begin() + start[static_cast<std::size_t>(v) + 1]}; };
  for (std::size_t v = 0; v < n; ++v) {
    const auto [first, last] = bucket(static_cast<int>(v));
    std::sort(first, last);
  }
  for (std::size_t v = 0; v < n; ++v) {
    const auto [first, last] = bucket(static_cast<int>(v));
    for (auto far = first; far != last; ++far) {
      const auto [back_first, back_last] = bucket(*far);
      if (!std::binary_search(back_first, back_last, static_cast<int>(v))) return false;
    }
  }
  return true;
}

}  // namespace hdeform::engine

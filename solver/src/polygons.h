#pragma once
// Faces as a file writes them, and their triangles: one rule for every mesh reader.
#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace hdeform::detail {

// The faces as written: their corners' vertex indices, 0-based and resolved.
struct Polygons {
  void add(const int* first, std::size_t size) {
    corners.insert(corners.end(), first, first + size);
    start.push_back(corners.size());
  }
  std::vector<int> corners;
  std::vector<std::size_t> start{0};  // polygon p: corners[start[p] .. start[p + 1])
  std::size_t count() const { return start.size() - 1; }
};

// Quads are split along their shorter diagonal (a tie takes 1-3), larger polygons into a fan
// from their first corner. Every polygon has three corners or more.
void triangulate(const Polygons& polygons, const Eigen::MatrixXd& positions, Eigen::MatrixXi& triangles);

}  // namespace hdeform::detail

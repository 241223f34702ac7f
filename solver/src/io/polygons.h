#pragma once
// Faces as a file writes them, and their triangles: one rule for every mesh reader.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <string_view>
#include <vector>

#include "hdeform/mesh.h"

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

// The mesh a reader has read: the points in file order, the polygons triangulated, then checked
// (validate_mesh, under `name`).
Mesh mesh_of(const std::vector<std::array<double, 3>>& points, const Polygons& polygons, std::string_view name);

}  // namespace hdeform::detail

#include "hdeform/subdivision.h"

#include "hdeform/errors.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace hdeform {

Subdivision subdivide(const Mesh& mesh) {
  validate_mesh(mesh);
  Subdivision result;
  const Eigen::Index n = mesh.vertex_count();
  const Eigen::Index m = mesh.triangle_count();
  result.original_vertices = n;
  std::unordered_map<std::uint64_t, int> midpoint_of;
  midpoint_of.reserve(static_cast<std::size_t>(2 * m));
  result.parents.reserve(static_cast<std::size_t>(3 * m / 2 + 1));
  auto midpoint = [&](int a, int b) {
    const auto low = static_cast<std::uint64_t>(std::min(a, b));
    const auto high = static_cast<std::uint64_t>(std::max(a, b));
    const auto [it, inserted] = midpoint_of.try_emplace((low << 32) | high, static_cast<int>(n + static_cast<Eigen::Index>(result.parents.size())));
    if (inserted) result.parents.push_back({static_cast<int>(low), static_cast<int>(high)});
    return it->second;
  };
  result.mesh.triangles.resize(4 * m, 3);
  for (Eigen::Index t = 0; t < m; ++t) {
    const int a = mesh.triangles(t, 0), b = mesh.triangles(t, 1), c = mesh.triangles(t, 2);
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    result.mesh.triangles.row(4 * t) << a, ab, ca;
    result.mesh.triangles.row(4 * t + 1) << ab, b, bc;
    result.mesh.triangles.row(4 * t + 2) << ca, bc, c;
    result.mesh.triangles.row(4 * t + 3) << ab, bc, ca;
  }
  result.mesh.positions.resize(n + static_cast<Eigen::Index>(result.parents.size()), 3);
  result.mesh.positions.topRows(n) = mesh.positions;
  for (std::size_t i = 0; i < result.parents.size(); ++i) {
    const auto [a, b] = result.parents[i];
    result.mesh.positions.row(n + static_cast<Eigen::Index>(i)) = 0.5 * (mesh.positions.row(a) + mesh.positions.row(b));
  }
  return result;
}

std::vector<int> subdivided_set(const std::vector<int>& vertices, const Subdivision& subdivision) {
  std::vector<bool> member(static_cast<std::size_t>(subdivision.original_vertices), false);
  for (const int v : vertices) {
    if (v < 0 || v >= subdivision.original_vertices) {
      throw InputError("vertex " + std::to_string(v) + " out of range (the mesh has " + std::to_string(subdivision.original_vertices) +
                       " vertices)");
    }
    member[static_cast<std::size_t>(v)] = true;
  }
  std::vector<int> result(vertices);
  std::sort(result.begin(), result.end());
  for (std::size_t i = 0; i < subdivision.parents.size(); ++i) {
    const auto [a, b] = subdivision.parents[i];
    if (member[static_cast<std::size_t>(a)] && member[static_cast<std::size_t>(b)]) {
      result.push_back(static_cast<int>(subdivision.original_vertices + static_cast<Eigen::Index>(i)));
    }
  }
  return result;
}

EditConstraints subdivided_constraints(const EditConstraints& constraints, const Subdivision& subdivision) {
  EditConstraints result;
  result.fixed = subdivided_set(constraints.fixed, subdivision);
  for (const auto& handle : constraints.handles) result.handles.push_back(subdivided_set(handle, subdivision));
  if (!constraints.region_of_interest.empty()) result.region_of_interest = subdivided_set(constraints.region_of_interest, subdivision);
  return result;
}

void add_relief(Mesh& mesh, double amplitude) {
  if (!std::isfinite(amplitude) || amplitude < 0.0) {
    throw InputError("relief amplitude must be a finite number, 0 or more; got " + std::to_string(amplitude));
  }
  if (amplitude == 0.0) return;
  const double diagonal = bounding_box_diagonal(mesh.positions);
  const Eigen::MatrixXd normals = vertex_normals(mesh.positions, mesh.triangles);
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    const Eigen::RowVector3d p = mesh.positions.row(v) / diagonal;
    const double pattern = std::sin(40 * p.x() + 7 * p.z()) * std::sin(40 * p.y()) + 0.5 * std::sin(90 * p.z() + 3 * p.x()) +
                           0.25 * std::sin(170 * (p.x() + p.y() + p.z()));
    mesh.positions.row(v) += amplitude * diagonal * pattern * normals.row(v);
  }
}

}  // namespace hdeform

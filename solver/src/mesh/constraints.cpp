#include "hdeform/constraints.h"

#include <algorithm>

#include "disjoint_sets.h"
#include "hdeform/counted.h"
#include "hdeform/errors.h"

namespace hdeform {
namespace {

void check_list(const std::vector<int>& list, Eigen::Index vertex_count, const std::string& what) {
  std::vector<int> sorted = list;
  std::sort(sorted.begin(), sorted.end());
  for (const int v : sorted) {
    if (v < 0 || v >= vertex_count) {
      throw InputError(what + ": vertex " + std::to_string(v) + " out of range (the mesh has " +
                       std::to_string(vertex_count) + " vertices)");
    }
  }
  const auto repeated = std::adjacent_find(sorted.begin(), sorted.end());
  if (repeated != sorted.end()) throw InputError(what + ": vertex " + std::to_string(*repeated) + " is listed twice");
}

}  // namespace

std::size_t VertexPartition::count(VertexRole which) const {
  return static_cast<std::size_t>(std::count(role.begin(), role.end(), which));
}

std::size_t VertexPartition::handle_count() const {
  const auto largest = std::max_element(handle_index.begin(), handle_index.end());
  return largest == handle_index.end() ? 0 : static_cast<std::size_t>(*largest + 1);
}

VertexPartition partition_vertices(const Mesh& mesh, const CotangentWeights& weights, const EditConstraints& constraints) {
  const auto n = mesh.vertex_count();
  const auto size = static_cast<std::size_t>(n);
  check_list(constraints.fixed, n, "fixed vertices");
  check_list(constraints.region_of_interest, n, "region of interest");
  for (std::size_t h = 0; h < constraints.handles.size(); ++h) {
    const std::string what = "handle " + std::to_string(h + 1);
    if (constraints.handles[h].empty()) throw InputError(what + " has no vertices");
    check_list(constraints.handles[h], n, what);
  }

  VertexPartition partition;
  partition.role.assign(size, VertexRole::Free);
  partition.handle_index.assign(size, -1);
  for (const int v : constraints.fixed) partition.role[static_cast<std::size_t>(v)] = VertexRole::Fixed;
  for (std::size_t h = 0; h < constraints.handles.size(); ++h) {
    for (const int v : constraints.handles[h]) {
      const auto vertex = static_cast<std::size_t>(v);
      if (partition.role[vertex] == VertexRole::Fixed) {
        throw InputError("vertex " + std::to_string(v) + " is both fixed and in handle " + std::to_string(h + 1));
      }
      if (partition.role[vertex] == VertexRole::Handle) {
        throw InputError("vertex " + std::to_string(v) + " is in handle " + std::to_string(partition.handle_index[vertex] + 1) +
                         " and in handle " + std::to_string(h + 1));
      }
      partition.role[vertex] = VertexRole::Handle;
      partition.handle_index[vertex] = static_cast<int>(h);
    }
  }
  if (!constraints.region_of_interest.empty()) {
    std::vector<bool> inside(size, false);
    for (const int v : constraints.region_of_interest) inside[static_cast<std::size_t>(v)] = true;
    for (std::size_t v = 0; v < size; ++v) {
      if (!inside[v] && partition.role[v] == VertexRole::Free) partition.role[v] = VertexRole::Fixed;
    }
  }

  // Components through regular triangles only: a degenerate triangle's element has a larger null
  // space, so it cannot be relied on to tie a vertex to a constraint.
  detail::DisjointSets components(size);
  std::vector<bool> referenced(size, false);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) referenced[static_cast<std::size_t>(mesh.triangles(t, k))] = true;
    if (weights.kind[static_cast<std::size_t>(t)] != ElementKind::Regular) continue;
    components.unite(mesh.triangles(t, 0), mesh.triangles(t, 1));
    components.unite(mesh.triangles(t, 1), mesh.triangles(t, 2));
  }
  std::vector<bool> constrained_root(size, false);
  std::vector<bool> fixed_root(size, false);
  std::vector<bool> free_root(size, false);
  for (std::size_t v = 0; v < size; ++v) {
    const auto root = static_cast<std::size_t>(components.find(static_cast<int>(v)));
    if (partition.role[v] != VertexRole::Free) constrained_root[root] = true;
    if (partition.role[v] == VertexRole::Fixed) fixed_root[root] = true;
    if (partition.role[v] == VertexRole::Free) free_root[root] = true;
  }
  // A part whose free vertices see only handles has a field of 1 throughout (nothing to solve
  // where a part is all handle, or a lone vertex).
  for (std::size_t v = 0; v < size; ++v) {
    const auto root = static_cast<std::size_t>(components.find(static_cast<int>(v)));
    if (partition.role[v] != VertexRole::Handle || fixed_root[root] || !free_root[root]) continue;
    const int handle = partition.handle_index[v];
    if (std::find(partition.handles_without_sink.begin(), partition.handles_without_sink.end(), handle) == partition.handles_without_sink.end()) {
      partition.handles_without_sink.push_back(handle);
    }
  }
  std::sort(partition.handles_without_sink.begin(), partition.handles_without_sink.end());
  std::vector<bool> stray_root(size, false);
  for (std::size_t v = 0; v < size; ++v) {
    const auto root = static_cast<std::size_t>(components.find(static_cast<int>(v)));
    if (constrained_root[root] || partition.role[v] != VertexRole::Free) continue;
    partition.role[v] = VertexRole::Fixed;
    if (!referenced[v]) {
      ++partition.unreferenced_vertices;
      continue;
    }
    ++partition.stray_vertices;
    if (!stray_root[root]) {
      stray_root[root] = true;
      ++partition.stray_components;
    }
  }

  for (std::size_t v = 0; v < size; ++v) {
    (partition.role[v] == VertexRole::Free ? partition.free_vertices : partition.constrained_vertices).push_back(static_cast<int>(v));
  }

  if (partition.unreferenced_vertices > 0) {
    partition.warnings.push_back(counted(partition.unreferenced_vertices, "unreferenced vertex (in no triangle) stays",
                                         "unreferenced vertices (in no triangle) stay") +
                                 " in place");
  }
  if (partition.stray_components > 0) {
    const bool one = partition.stray_components == 1;
    partition.warnings.push_back(counted(partition.stray_components, "part", "parts") + " of the mesh (" +
                                 counted(partition.stray_vertices, "vertex", "vertices") +
                                 (one ? ") has no fixed or handle vertex and stays in place" : ") have no fixed or handle vertex and stay in place"));
  }
  return partition;
}

}  // namespace hdeform

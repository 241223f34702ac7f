#include "hdeform/mesh_check.h"

#include <algorithm>
#include <cstdint>

#include "disjoint_sets.h"

namespace hdeform {

std::vector<std::string> MeshInspection::warnings() const {
  std::vector<std::string> lines;
  if (degenerate_triangles > 0) {
    lines.push_back(std::to_string(degenerate_triangles) + " zero-area or needle triangles (their weights are bounded)");
  }
  if (ignored_triangles > 0) {
    lines.push_back(std::to_string(ignored_triangles) +
                    " duplicated triangles or triangles with a repeated vertex (left out of the operator)");
  }
  if (nonmanifold_edges > 0) lines.push_back(std::to_string(nonmanifold_edges) + " non-manifold edges (shared by more than two triangles)");
  if (components > 1) lines.push_back(std::to_string(components) + " connected components");
  if (unreferenced_vertices > 0) lines.push_back(std::to_string(unreferenced_vertices) + " unreferenced vertices (in no triangle)");
  return lines;
}

MeshInspection inspect_mesh(const Mesh& mesh, const CotangentWeights& weights) {
  MeshInspection inspection;
  inspection.degenerate_triangles = weights.count(ElementKind::Degenerate);
  inspection.ignored_triangles = weights.count(ElementKind::Ignored);

  const auto n = static_cast<std::size_t>(mesh.vertex_count());
  std::vector<std::uint64_t> edges;
  edges.reserve(static_cast<std::size_t>(mesh.triangle_count()) * 3);
  detail::DisjointSets components(n);
  std::vector<bool> referenced(n, false);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<std::uint32_t>(mesh.triangles(t, k));
      const auto b = static_cast<std::uint32_t>(mesh.triangles(t, (k + 1) % 3));
      referenced[a] = true;
      if (a == b) continue;
      edges.push_back((static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b));
      components.unite(static_cast<int>(a), static_cast<int>(b));
    }
  }
  std::sort(edges.begin(), edges.end());
  for (std::size_t k = 0; k < edges.size();) {
    std::size_t run = k;
    while (run < edges.size() && edges[run] == edges[k]) ++run;
    if (run - k == 1) ++inspection.boundary_edges;
    if (run - k > 2) ++inspection.nonmanifold_edges;
    k = run;
  }
  for (std::size_t v = 0; v < n; ++v) {
    if (!referenced[v]) ++inspection.unreferenced_vertices;
    else if (components.find(static_cast<int>(v)) == static_cast<int>(v)) ++inspection.components;
  }
  return inspection;
}

}  // namespace hdeform

#include "hdeform/mesh_check.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>

#include "disjoint_sets.h"
#include "edge_counts.h"
#include "hdeform/counted.h"

namespace hdeform {

std::vector<std::string> MeshInspection::warnings() const {
  std::vector<std::string> lines;
  if (degenerate_triangles > 0) {
    lines.push_back(counted(degenerate_triangles, "zero-area or needle triangle", "zero-area or needle triangles") +
                    " (their weights are bounded)");
  }
  if (ignored_triangles > 0) {
    lines.push_back(counted(ignored_triangles, "duplicated triangle or triangle", "duplicated triangles or triangles") +
                    " with a repeated vertex (left out of the operator)");
  }
  if (nonmanifold_edges > 0) {
    lines.push_back(counted(nonmanifold_edges, "non-manifold edge", "non-manifold edges") + " (shared by more than two triangles)");
  }
  if (nonmanifold_vertices > 0) {
    lines.push_back(counted(nonmanifold_vertices, "non-manifold vertex", "non-manifold vertices") +
                    " (where separate fans of triangles meet)");
  }
  if (duplicated_vertices > 0) {
    lines.push_back(counted(duplicated_vertices, "duplicated vertex", "duplicated vertices") +
                    " (at the same position as another vertex: the mesh is not joined there)");
  }
  if (components > 1) lines.push_back(std::to_string(components) + " connected components");
  if (unreferenced_vertices > 0) {
    lines.push_back(counted(unreferenced_vertices, "unreferenced vertex", "unreferenced vertices") + " (in no triangle)");
  }
  return lines;
}

namespace {

// Boundary and non-manifold edges (by how many triangles hold each edge), connected components
// and unreferenced vertices.
void count_edges_and_components(const Mesh& mesh, const std::vector<bool>& referenced, MeshInspection& inspection) {
  const auto n = referenced.size();
  detail::DisjointSets components(n);
  const detail::EdgeCounts edges = detail::count_edges(mesh.triangles, n, false, &components);
  inspection.boundary_edges = edges.boundary;
  inspection.nonmanifold_edges = edges.nonmanifold;
  for (std::size_t v = 0; v < n; ++v) {
    if (!referenced[v]) ++inspection.unreferenced_vertices;
    else if (components.find(static_cast<int>(v)) == static_cast<int>(v)) ++inspection.components;
  }
}

// A vertex is manifold when the triangles around it form one fan: in its link (the opposite
// edges of its triangles) every neighbour is reachable from every other.
std::size_t count_nonmanifold_vertices(const Mesh& mesh) {
  struct Link {
    int a, b;  // the edge of a triangle opposite the vertex
  };
  // The links of each vertex together, by a counting sort on the vertex.
  const auto n = static_cast<std::size_t>(mesh.vertex_count());
  std::vector<std::size_t> start(n + 1, 0);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    const int i = mesh.triangles(t, 0), j = mesh.triangles(t, 1), k = mesh.triangles(t, 2);
    if (i == j || j == k || k == i) continue;
    for (const int v : {i, j, k}) ++start[static_cast<std::size_t>(v) + 1];
  }
  for (std::size_t v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<Link> links(start[n]);
  std::vector<std::size_t> next(start.begin(), start.end() - 1);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    const int i = mesh.triangles(t, 0), j = mesh.triangles(t, 1), k = mesh.triangles(t, 2);
    if (i == j || j == k || k == i) continue;
    links[next[static_cast<std::size_t>(i)]++] = {j, k};
    links[next[static_cast<std::size_t>(j)]++] = {k, i};
    links[next[static_cast<std::size_t>(k)]++] = {i, j};
  }
  std::atomic<std::size_t> nonmanifold{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<int> neighbours;
    detail::DisjointSets link;
    std::size_t found = 0;
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      if (start[v] == start[v + 1]) continue;
      neighbours.clear();
      for (std::size_t c = start[v]; c < start[v + 1]; ++c) {
        neighbours.push_back(links[c].a);
        neighbours.push_back(links[c].b);
      }
      std::sort(neighbours.begin(), neighbours.end());
      neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
      link.reset(neighbours.size());
      const auto local = [&](int vertex) { return static_cast<int>(std::lower_bound(neighbours.begin(), neighbours.end(), vertex) - neighbours.begin()); };
      for (std::size_t c = start[v]; c < start[v + 1]; ++c) link.unite(local(links[c].a), local(links[c].b));
      std::size_t fans = 0;
      for (std::size_t k = 0; k < neighbours.size(); ++k) fans += link.find(static_cast<int>(k)) == static_cast<int>(k) ? 1 : 0;
      if (fans > 1) ++found;
    }
    nonmanifold += found;
  });
  return nonmanifold.load();
}

// Referenced vertices at exactly the same position as another (each one after the first counts).
std::size_t count_duplicated_vertices(const Mesh& mesh, const std::vector<bool>& referenced) {
  std::vector<int> order;
  for (std::size_t v = 0; v < referenced.size(); ++v) {
    if (referenced[v]) order.push_back(static_cast<int>(v));
  }
  const auto position = [&](int v) { return std::array<double, 3>{mesh.positions(v, 0), mesh.positions(v, 1), mesh.positions(v, 2)}; };
  tbb::parallel_sort(order.begin(), order.end(), [&](int x, int y) { return position(x) < position(y); });
  std::size_t duplicated = 0;
  for (std::size_t k = 1; k < order.size(); ++k) {
    if (position(order[k]) == position(order[k - 1])) ++duplicated;
  }
  return duplicated;
}

}  // namespace

MeshInspection inspect_mesh(const Mesh& mesh, const CotangentWeights& weights) {
  MeshInspection inspection;
  inspection.degenerate_triangles = weights.count(ElementKind::Degenerate);
  inspection.ignored_triangles = weights.count(ElementKind::Ignored);
  const auto n = static_cast<std::size_t>(mesh.vertex_count());
  std::vector<bool> referenced(n, false);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) referenced[static_cast<std::size_t>(mesh.triangles(t, k))] = true;
  }
  // Three independent checks, side by side.
  tbb::parallel_invoke([&] { count_edges_and_components(mesh, referenced, inspection); },
                       [&] { inspection.nonmanifold_vertices = count_nonmanifold_vertices(mesh); },
                       [&] { inspection.duplicated_vertices = count_duplicated_vertices(mesh, referenced); });
  return inspection;
}

}  // namespace hdeform

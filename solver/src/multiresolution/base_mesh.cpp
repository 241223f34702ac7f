// The base mesh of multiresolution editing: the fine mesh simplified by edge collapses that keep
// its topology, and the topology each is checked against.
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

#include "edge_collapse.h"
#include "hdeform/counted.h"
#include "hdeform/errors.h"
#include "hdeform/multiresolution.h"
#include "hdeform/trace.h"
#include "mesh/disjoint_sets.h"
#include "mesh/edge_counts.h"

namespace hdeform {

bool MeshTopology::same_as(const MeshTopology& other) const {
  return euler_characteristic() == other.euler_characteristic() && components == other.components &&
         boundary_edges == other.boundary_edges && nonmanifold_edges == other.nonmanifold_edges;
}

std::string MeshTopology::describe() const {
  return counted(static_cast<std::size_t>(vertices), "vertex", "vertices") + ", Euler characteristic " +
         std::to_string(euler_characteristic()) + ", " + counted(static_cast<std::size_t>(components), "component", "components") + ", " +
         counted(static_cast<std::size_t>(boundary_edges), "boundary edge", "boundary edges") + ", " +
         counted(static_cast<std::size_t>(nonmanifold_edges), "non-manifold edge", "non-manifold edges");
}

MeshTopology mesh_topology(const Mesh& mesh) {
  MeshTopology topology;
  topology.triangles = mesh.triangle_count();
  const auto n = static_cast<std::size_t>(mesh.vertex_count());
  detail::DisjointSets sets(n);
  const detail::EdgeCounts edges = detail::count_edges(mesh.triangles, n, true, &sets);
  topology.edges = static_cast<Eigen::Index>(edges.edges);
  topology.boundary_edges = static_cast<Eigen::Index>(edges.boundary);
  topology.nonmanifold_edges = static_cast<Eigen::Index>(edges.nonmanifold);
  std::vector<char> referenced(n, 0);
  for (const int v : mesh.triangles.reshaped()) referenced[static_cast<std::size_t>(v)] = 1;
  for (std::size_t v = 0; v < n; ++v) {
    if (!referenced[v]) continue;
    ++topology.vertices;
    if (sets.find(static_cast<int>(v)) == static_cast<int>(v)) ++topology.components;
  }
  return topology;
}

BaseMesh simplify_to_base(const Mesh& fine, Eigen::Index target_vertices, const std::function<void(double)>& collapsed_share) {
  validate_mesh(fine, "fine mesh");
  std::vector<char> referenced(static_cast<std::size_t>(fine.vertex_count()), 0);
  for (const int v : fine.triangles.reshaped()) referenced[static_cast<std::size_t>(v)] = 1;
  if (target_vertices >= std::count(referenced.begin(), referenced.end(), 1)) {
    BaseMesh base;
    base.mesh = fine;
    base.fine_vertex.resize(static_cast<std::size_t>(fine.vertex_count()));
    std::iota(base.fine_vertex.begin(), base.fine_vertex.end(), 0);
    return base;
  }

  const trace::Scope traced("base mesh (edge collapses)", "set-up");
  // The fine mesh's topology, for the check at the end, beside the collapses. The collapses stay
  // on this thread, which reports their progress; isolated, so that it does not take up the
  // topology's task while a pass waits.
  MeshTopology fine_topology;
  tbb::task_group beside;
  beside.run([&] { fine_topology = mesh_topology(fine); });
  detail::CollapsedMesh collapsed;
  try {
    tbb::this_task_arena::isolate([&] { collapsed = detail::collapse_edges(fine, target_vertices, collapsed_share); });
  } catch (...) {
    beside.wait();
    throw;
  }
  beside.wait();
  BaseMesh base;
  base.simplification_error = collapsed.largest_error / std::max(bounding_box_diagonal(fine.positions), 1e-300);
  std::vector<int> base_of_fine(static_cast<std::size_t>(fine.vertex_count()), -1);
  for (std::size_t v = 0; v < collapsed.kept.size(); ++v) {
    if (!collapsed.kept[v]) continue;
    base_of_fine[v] = static_cast<int>(base.fine_vertex.size());
    base.fine_vertex.push_back(static_cast<int>(v));
  }
  base.mesh.positions.resize(static_cast<Eigen::Index>(base.fine_vertex.size()), 3);
  for (std::size_t j = 0; j < base.fine_vertex.size(); ++j) {
    base.mesh.positions.row(static_cast<Eigen::Index>(j)) = fine.positions.row(base.fine_vertex[j]);
  }
  base.mesh.triangles.resize(collapsed.triangles.rows(), 3);
  for (Eigen::Index t = 0; t < collapsed.triangles.rows(); ++t) {
    for (int k = 0; k < 3; ++k) base.mesh.triangles(t, k) = base_of_fine[static_cast<std::size_t>(collapsed.triangles(t, k))];
  }
  // The collapses refuse every change of topology; this says so, or why not.
  const MeshTopology base_topology = mesh_topology(base.mesh);
  if (!base_topology.same_as(fine_topology)) {
    throw SolveError("the base mesh of " + std::to_string(base.mesh.vertex_count()) + " vertices has " + base_topology.describe() +
                     " where the mesh has " + fine_topology.describe());
  }
  return base;
}

}  // namespace hdeform

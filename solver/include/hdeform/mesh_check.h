#pragma once
/// @file
/// Legal but troublesome geometry, counted so that the user is told about it. Every case listed
/// here has a defined behaviour in the solver (see laplacian.h and constraints.h).
#include <string>
#include <vector>

#include "hdeform/laplacian.h"
#include "hdeform/mesh.h"

namespace hdeform {

/// What the inspection of a mesh found: counts of each troublesome case, for warnings.
struct MeshInspection {
  std::size_t degenerate_triangles = 0;  ///< zero-area or needle: bounded weights
  std::size_t ignored_triangles = 0;     ///< duplicates and triangles with a repeated vertex
  std::size_t nonmanifold_edges = 0;     ///< edges shared by more than two triangles
  std::size_t nonmanifold_vertices = 0;  ///< where separate fans of triangles meet
  std::size_t duplicated_vertices = 0;   ///< at the same position as another (referenced) vertex
  std::size_t boundary_edges = 0;
  std::size_t components = 0;            ///< connected through triangles, unreferenced vertices excluded
  std::size_t unreferenced_vertices = 0;

  /// One line per finding that a user should know about (boundary edges are normal).
  std::vector<std::string> warnings() const;
};

/// Inspects a mesh with its weights (degenerate, duplicated and non-manifold elements, stray parts).
MeshInspection inspect_mesh(const Mesh& mesh, const CotangentWeights& weights);

}  // namespace hdeform

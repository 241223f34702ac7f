#pragma once
/// @file
/// Midpoint subdivision: every triangle split into four at its edges' midpoints (no smoothing, so
/// the surface keeps its shape and every original vertex its position and index). What `hdeform
/// bench --subdivide` uses to measure meshes four, sixteen... times larger than a file holds.
#include <array>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/mesh.h"

namespace hdeform {

/// A subdivided mesh and, per new vertex, the two vertices whose edge it splits.
struct Subdivision {
  Mesh mesh;  ///< the original vertices first, unchanged, then one per edge
  /// Per new vertex (mesh index original_vertices + i): the edge's two ends, lower index first.
  std::vector<std::array<int, 2>> parents;
  Eigen::Index original_vertices = 0;
};

/// One step. New vertices are numbered in the order their edges first occur (triangle 0's edges
/// a-b, b-c, c-a first); triangle t becomes triangles 4t .. 4t+3: (a, ab, ca), (ab, b, bc),
/// (ca, bc, c), (ab, bc, ca), so orientation is kept. Runs validate_mesh.
Subdivision subdivide(const Mesh& mesh);

/// A vertex set of the original mesh on the subdivided one: its vertices, and every new vertex
/// whose two parents are both in it (ascending). Throws InputError for a vertex out of range.
std::vector<int> subdivided_set(const std::vector<int>& vertices, const Subdivision& subdivision);

/// Fixed set, handles and region of interest carried over, each by subdivided_set.
EditConstraints subdivided_constraints(const EditConstraints& constraints, const Subdivision& subdivision);

/// Relief, for measuring meshes whose detail is real: every vertex displaced along its normal by
/// `amplitude` × the bounding box's diagonal × a fixed pattern of three frequencies of its
/// position (|pattern| ≤ 1.75; the finest wavelength about 1/47 of the diagonal). What `hdeform
/// bench --relief` applies after `--subdivide`. Amplitude 0 leaves the positions as they are.
/// Throws InputError for a negative or non-finite amplitude.
void add_relief(Mesh& mesh, double amplitude);

}  // namespace hdeform

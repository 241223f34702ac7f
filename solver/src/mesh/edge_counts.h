#pragma once
// How many triangles hold each edge of a triangle list (private to the solver): what a mesh's
// inspection and its topology count. By a counting sort on each edge's lower vertex, so that the
// cost is linear in the triangles where sorting every edge's key was most of an inspection.
#include <Eigen/Core>

#include <cstddef>

#include "disjoint_sets.h"

namespace hdeform::detail {

struct EdgeCounts {
  std::size_t edges = 0;        // distinct edges
  std::size_t boundary = 0;     // in one triangle
  std::size_t nonmanifold = 0;  // in more than two
};

// `self_edges`: whether a triangle's edge from a vertex to itself (a repeated corner) counts as an
// edge. `components`, when given, has the two ends of every other edge united.
EdgeCounts count_edges(const Eigen::MatrixXi& triangles, std::size_t vertex_count, bool self_edges, DisjointSets* components);

}  // namespace hdeform::detail

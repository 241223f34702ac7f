#pragma once
/// @file
/// Vertex classes of an edit (paper §5): fixed vertices (sinks) stay at rest, handle vertices
/// (sources, the edited region) follow their handle's transform, free vertices are solved for.
#include <cstdint>
#include <string>
#include <vector>

#include "hdeform/laplacian.h"
#include "hdeform/mesh.h"

namespace hdeform {

/// What a vertex is in an edit: solved for, held at rest (a sink), or moved by a handle (a source).
enum class VertexRole : std::uint8_t { Free, Fixed, Handle };

/// What the user asked for. Indices are 0-based vertex ids.
struct EditConstraints {
  std::vector<int> fixed;
  std::vector<std::vector<int>> handles;  ///< one vertex list per handle
  std::vector<int> region_of_interest;    ///< empty: the whole mesh; vertices outside it are fixed

  friend bool operator==(const EditConstraints&, const EditConstraints&) = default;
};

/// The classes that are solved with: the ROI applied and every vertex that no constraint reaches
/// through regular triangles (another component, an unreferenced vertex, a vertex held only by
/// degenerate triangles) fixed in place, so that L_ff is always positive definite.
struct VertexPartition {
  std::vector<VertexRole> role;      ///< per vertex
  std::vector<int> handle_index;     ///< per vertex: its handle, or −1
  std::vector<int> free_vertices;    ///< ascending
  std::vector<int> constrained_vertices;  ///< ascending
  std::size_t stray_vertices = 0;    ///< fixed because nothing constrains their component
  /// Handles (0-based) with a vertex in a part of the mesh whose free vertices meet no fixed vertex:
  /// there the field is 1 everywhere, the handle would move the part rigidly (the Deformer refuses).
  std::vector<int> handles_without_sink;
  std::size_t stray_components = 0;
  std::size_t unreferenced_vertices = 0;
  std::vector<std::string> warnings;

  /// The number of vertices with that role.
  std::size_t count(VertexRole which) const;
  /// The number of handles (the largest handle index plus one).
  std::size_t handle_count() const;
};

/// Throws InputError for an index out of range, a vertex that is both fixed and in a handle or
/// in two handles, a handle with no vertices, or a repeated vertex within one list.
VertexPartition partition_vertices(const Mesh& mesh, const CotangentWeights& weights, const EditConstraints& constraints);

}  // namespace hdeform

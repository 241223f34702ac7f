#pragma once
// Quadric-error halfedge collapses that keep a mesh's topology (private to multiresolution.cpp).
//
// A halfedge collapse u → v removes u and keeps v where it is, so the surviving vertices are
// vertices of the input, at their own positions. Each candidate's cost is Garland and Heckbert's
// quadric error (the squared distances from v to the planes of u's and v's original triangles,
// area-weighted, per unit area) plus a little of the edge's squared length; the cheapest goes first. A collapse is refused when it would change the
// topology or fold the surface:
//  - the link condition (u and v share exactly the two neighbours opposite the edge), so no
//    handle closes and no non-manifold edge appears;
//  - neither opposite vertex is left with fewer than three neighbours (no tetrahedron flattens);
//  - u is not on a boundary or a non-manifold edge, and has one fan of triangles (those stay);
//  - no triangle around u turns by more than about 78°, becomes degenerate, or becomes a sliver.
// Deterministic: ties go by vertex index.
#include <Eigen/Core>
#include <functional>
#include <vector>

#include "hdeform/mesh.h"

namespace hdeform::detail {

struct CollapsedMesh {
  Eigen::MatrixXi triangles;  // indices of the input's vertices
  std::vector<char> kept;     // per input vertex: still referenced
  Eigen::Index vertices = 0;  // kept vertices
  double largest_error = 0.0;  // the largest collapse's root mean squared distance to its planes
};

// Collapses until `target_vertices` of the referenced vertices remain, or no collapse is allowed;
// plus what components too small for their share of the target must keep (Collapser::target_for).
// `collapsed_share`, if given, is called on the calling thread after each pass of collapses with
// the share of the collapses to the target done so far (0 to 1).
CollapsedMesh collapse_edges(const Mesh& mesh, Eigen::Index target_vertices, const std::function<void(double)>& collapsed_share = {});

}  // namespace hdeform::detail

#pragma once
// The meshes and options the multiresolution tests share (test_base_mesh.cpp,
// test_detail_encoding.cpp, test_multiresolution.cpp).
#include <Eigen/Core>

#include "hdeform/constraints.h"
#include "hdeform/deformer.h"
#include "hdeform/handle_transform.h"
#include "hdeform/mesh.h"

namespace hdeform::test {

// A torus (genus 1, closed) or, with `open`, a tube (its two ends are boundary loops): `around`
// segments along the big circle, `across` around the tube, with a ripple so that no collapse is
// free.
Mesh torus(int around, int across, bool open = false);

// The bar subdivided twice, with relief: displaced along its normals by a pattern of three
// frequencies (the finest about two edges long), and its demo edit (a twist of the top end).
struct Relief {
  Mesh mesh;
  EditConstraints constraints;
  HandleTransform transform;
  double diagonal = 0.0;
};
Relief bar_with_relief();

// A sphere with a ripple whose edges are half as long on its northern half as on its southern (four
// times the vertices per area): rings of latitude as far apart as the local edge is long, each with
// as many vertices as that length allows, neighbouring rings zipped together by angle.
Mesh sphere_denser_in_the_north(double southern_edge);

// A deformer's options that solve on a base of `base_vertices`.
DeformerOptions multiresolution(Eigen::Index base_vertices);

}  // namespace hdeform::test

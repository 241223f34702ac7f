#pragma once
/// @file
/// How much a deformation stretches the surface, in the form other tools report it, so that
/// results can be compared with theirs (CGAL's and libigl's ARAP examples, the README's tables).
#include <Eigen/Core>

#include "hdeform/mesh.h"

namespace hdeform {

/// The mean over the mesh's distinct edges of |l'/l − 1|, l and l' an edge's rest and deformed
/// lengths; edges of zero rest length are left out. `deformed` has the rest mesh's vertices.
double mean_edge_strain(const Mesh& rest, const Eigen::MatrixXd& deformed);

}  // namespace hdeform

#pragma once
// Harmonic coordinates (paper §6): k markers give k harmonic fields, field j equal to 1 at marker
// j and 0 at the other markers. All k columns are solved against one factorization of L_ff with
// the markers as the constrained vertices. By linearity the rows sum to 1 (partition of unity),
// and by the maximum principle every value lies in [0, 1] (clamped: obtuse triangles can
// overshoot by a few 1e-6, as for the §5 field). A triangle's coordinate is the mean of its
// corners' rows.
#include <Eigen/Core>
#include <span>

#include "hdeform/constraints.h"
#include "hdeform/dirichlet_system.h"

namespace hdeform {

// `partition` must have exactly the markers as its fixed vertices, plus any stray vertices it
// fixed itself (a component without a marker): those get 1/k in every column. n × k.
Eigen::MatrixXd harmonic_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers);

}  // namespace hdeform

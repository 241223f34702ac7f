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

// Coordinates one per row (a vertex's or a triangle's k values side by side): what the matching
// reads.
using CoordinateRows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// `partition` must have exactly the markers as its fixed vertices, plus any stray vertices it
// fixed itself (a component without a marker): those get 1/k in every column. n × k.
Eigen::MatrixXd harmonic_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers);

// The triangles' coordinates, the mean of their corners' (m × k): the same values as
// barycenter_values(harmonic_coordinates(...), triangles), bit for bit, computed from the solve
// without the n × k matrix between (for a camel with 124 markers, 22 MB less to write and read).
CoordinateRows triangle_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers,
                                    const Eigen::MatrixXi& triangles);

}  // namespace hdeform

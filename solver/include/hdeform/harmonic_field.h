#pragma once
/// @file
/// Harmonic guidance field (paper §5): 1 at the handle vertices (sources), 0 at the fixed vertices
/// (sinks), harmonic elsewhere: L_ff h_f = −L_fc h_c. By the maximum principle it lies in [0, 1]
/// with no interior extremum. Obtuse triangles give the cotangent Laplacian positive off-diagonal
/// entries, and the discrete solution can then overshoot by a few 1e-6 (buddha-206k: 1 + 3e-6);
/// h is a blend weight, so it is clamped to [0, 1].
#include <Eigen/Core>

#include "hdeform/constraints.h"
#include "hdeform/dirichlet_system.h"

namespace hdeform {

/// The field h (one value per vertex): 1 at the partition's handle vertices, 0 at its fixed ones, harmonic between.
Eigen::VectorXd harmonic_field(const DirichletSystem& system, const VertexPartition& partition);

}  // namespace hdeform

#pragma once
/// @file
/// Whether a mesh's back faces can ever show: the renderer culls them on a closed mesh.
#include <Eigen/Core>

namespace hdeform::engine {

/// Whether every directed edge a → b of a triangle has its reverse b → a in some triangle (each
/// edge between two consistently oriented triangles): then no back face is ever in view. Empty:
/// false. `triangles` index vertices below `vertex_count`.
bool every_edge_has_its_reverse(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count);

}  // namespace hdeform::engine

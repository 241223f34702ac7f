#pragma once
/// @file
/// A coarser stand-in for a large mesh, drawn while it moves on a CPU device: there a frame's cost
/// is setting up triangles (lavapipe: about 30 ms for 206K), so a drag answers within a frame only
/// with far fewer of them. The proxy's triangles join vertices of the mesh itself, so it follows
/// every new solution with no mapping and carries the same field and classes.
#include <Eigen/Core>

namespace hdeform::engine {

/// The triangle count a proxy aims at; meshes up to twice this draw in full even while moving.
inline constexpr Eigen::Index kProxyTriangles = 24000;

/// Triangles over a subset of the mesh's vertices (indices into `positions`, topology kept:
/// meshoptimizer's edge-collapse simplifier, at most 2% of the mesh's extent off its surface),
/// about `target` of them; empty when the mesh has no more than twice `target` (nothing to gain).
/// A mesh of more than 16 times `target` is first clustered on a grid to 16 times `target`,
/// within 0.5% of its extent: there a feature smaller than that (a tiny hole) may close.
Eigen::MatrixXi proxy_triangles(const Eigen::MatrixXi& triangles, const Eigen::MatrixXd& positions, Eigen::Index target = kProxyTriangles);

}  // namespace hdeform::engine

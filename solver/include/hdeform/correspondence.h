#pragma once
/// @file
/// Triangle correspondence by harmonic coordinates (paper §6): each target triangle is matched to
/// the source triangle whose coordinate is nearest in the 2-norm — over all k components, or over
/// the target triangle's n largest components only (3 ≤ n ≤ k), which the paper found enough.
/// The map is not a bijection: source triangles may receive many target triangles or none.
#include <Eigen/Core>

#include <vector>

#include "hdeform/harmonic_coordinates.h"

namespace hdeform {

/// The matching's result: per target triangle, its source triangle and their distance in harmonic coordinates.
struct TriangleMatch {
  std::vector<int> source;        ///< per target triangle: the matched source triangle
  std::vector<double> distance;   ///< ... and the distance between their coordinates
};

/// `target` is m_t × k, `source` m_s × k (one coordinate per row). top_n = 0 compares all k
/// components; otherwise 3 ≤ top_n ≤ k (throws std::invalid_argument outside). Exact nearest
/// neighbours, ties to the lower source row, found in one tree of boxes over the source
/// coordinates that serves all k components and every set of n alike; queries run in parallel.
TriangleMatch match_triangles(const CoordinateRows& target, const CoordinateRows& source, int top_n = 0);
/// The same with the coordinates per vertex: a triangle's row, the mean of its corners' (as
/// triangle_coordinates gives it), is formed where it is needed, so that neither m × k matrix is
/// written.
TriangleMatch match_triangles(const VertexCoordinates& target, const Eigen::MatrixXi& target_triangles, const VertexCoordinates& source,
                              const Eigen::MatrixXi& source_triangles, int top_n = 0);

}  // namespace hdeform

#pragma once
/// @file
/// Harmonic coordinates (paper §6): k markers give k harmonic fields, field j equal to 1 at marker
/// j and 0 at the other markers. All k columns are solved against one factorization of L_ff with
/// the markers as the constrained vertices. By linearity the rows sum to 1 (partition of unity),
/// and by the maximum principle every value lies in [0, 1] (clamped: obtuse triangles can
/// overshoot by a few 1e-6, as for the §5 field). A triangle's coordinate is the mean of its
/// corners' rows.
#include <Eigen/Core>
#include <span>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/dirichlet_system.h"

namespace hdeform {

/// Coordinates one per row (a vertex's or a triangle's k values side by side): what the matching
/// reads.
using CoordinateRows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// The vertices' coordinates as solved: the free vertices' rows (in the system's order, clamped)
/// and, implied, a marker's unit row or, for a stray vertex (a component without a marker, fixed
/// by the partition), 1/k everywhere. Independent of the system once made.
class VertexCoordinates {
 public:
  // `partition` must have exactly the markers as its fixed vertices, plus any stray vertices.
  /// Solves the k coordinate columns against `system` (whose fixed vertices are the markers).
  VertexCoordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers);

  /// The number of vertices of the mesh.
  Eigen::Index vertex_count() const { return static_cast<Eigen::Index>(row_of_vertex_.size()); }
  /// k, the number of markers.
  int columns() const { return columns_; }
  /// Vertex v's coordinates; `buffer` (columns() doubles) holds them for a constrained vertex.
  const double* row(int v, double* buffer) const;
  /// A triangle's coordinates, the mean of its corners', into `out`; `scratch`: 3 × columns().
  void triangle_row(const Eigen::MatrixXi& triangles, Eigen::Index t, double* out, double* scratch) const;

 private:
  CoordinateRows free_;  ///< free rows × SparseCholesky::fast_solve_stride(columns_): the first columns_ of a row are its values
  int columns_ = 0;
  std::vector<int> row_of_vertex_;  ///< −1 for a constrained vertex
  std::vector<int> marker_of_;      ///< its marker, −1 for a stray one
  double stray_value_ = 0.0;
};

/// n × k.
Eigen::MatrixXd harmonic_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers);

/// The triangles' coordinates (m × k): the same values as barycenter_values(harmonic_coordinates(...),
/// triangles), bit for bit, without the n × k matrix between.
CoordinateRows triangle_coordinates(const VertexCoordinates& coordinates, const Eigen::MatrixXi& triangles);
/// The same, solving the coordinates first.
CoordinateRows triangle_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers,
                                    const Eigen::MatrixXi& triangles);

}  // namespace hdeform

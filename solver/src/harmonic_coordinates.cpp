#include "hdeform/harmonic_coordinates.h"

#include <tbb/parallel_for.h>

namespace hdeform {
namespace {

constexpr Eigen::Index kRowGrain = 256;

// The coordinates of the free vertices, row by row in factor order (row r is the vertex
// system.vertex_of_row()[r]), clamped to [0, 1]; a constrained vertex's row is a marker's unit
// row or, for a stray vertex, 1/k everywhere (`marker_of[v]`: its marker, −1 otherwise).
struct SolvedCoordinates {
  CoordinateRows free;
  std::vector<int> marker_of;
  double stray_value = 0.0;

  // Vertex v's coordinates, through a buffer for a constrained one.
  const double* row(const DirichletSystem& system, int v, double* buffer) const {
    if (const int r = system.row_of_vertex()[static_cast<std::size_t>(v)]; r >= 0) return free.row(r).data();
    const auto k = free.cols();
    if (const int marker = marker_of[static_cast<std::size_t>(v)]; marker >= 0) {
      std::fill(buffer, buffer + k, 0.0);
      buffer[marker] = 1.0;
    } else {
      std::fill(buffer, buffer + k, stray_value);
    }
    return buffer;
  }
};

SolvedCoordinates solve_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers) {
  const auto k = static_cast<Eigen::Index>(markers.size());
  SolvedCoordinates solved;
  solved.marker_of.assign(partition.role.size(), -1);
  for (Eigen::Index j = 0; j < k; ++j) solved.marker_of[static_cast<std::size_t>(markers[static_cast<std::size_t>(j)])] = static_cast<int>(j);
  solved.stray_value = 1.0 / static_cast<double>(k);
  // Right-hand side −L_fc X_c, each column summed over the coupling in its order (as
  // DirichletSystem::solve sums it).
  solved.free.resize(system.free_count(), k);  // first written by the threads below: its pages faulted in on both cores
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, system.free_count(), kRowGrain), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index row = range.begin(); row != range.end(); ++row) {
      auto values = solved.free.row(row);
      values.setZero();
      for (const auto& entry : system.coupling(static_cast<int>(row))) {
        if (const int marker = solved.marker_of[static_cast<std::size_t>(entry.vertex)]; marker >= 0) {
          values(marker) -= entry.weight;
        } else {
          for (Eigen::Index c = 0; c < k; ++c) values(c) -= entry.weight * solved.stray_value;
        }
      }
    }
  });
  if (system.free_count() > 0 && k > 0) system.factor().solve_block(solved.free.data(), static_cast<int>(k), static_cast<int>(k));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, system.free_count(), kRowGrain), [&](const tbb::blocked_range<Eigen::Index>& range) {
    auto rows = solved.free.middleRows(range.begin(), range.size());
    rows = rows.cwiseMax(0.0).cwiseMin(1.0);
  });
  return solved;
}

}  // namespace

Eigen::MatrixXd harmonic_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers) {
  const SolvedCoordinates solved = solve_coordinates(system, partition, markers);
  const auto n = static_cast<Eigen::Index>(partition.role.size());
  Eigen::MatrixXd values(n, static_cast<Eigen::Index>(markers.size()));
  std::vector<double> buffer(markers.size());
  for (Eigen::Index v = 0; v < n; ++v) {
    values.row(v) = Eigen::Map<const Eigen::RowVectorXd>(solved.row(system, static_cast<int>(v), buffer.data()), values.cols());
  }
  return values;
}

CoordinateRows triangle_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers,
                                    const Eigen::MatrixXi& triangles) {
  const SolvedCoordinates solved = solve_coordinates(system, partition, markers);
  const auto k = static_cast<Eigen::Index>(markers.size());
  CoordinateRows values(triangles.rows(), k);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, triangles.rows(), kRowGrain), [&](const tbb::blocked_range<Eigen::Index>& range) {
    std::vector<double> buffers(3 * static_cast<std::size_t>(k));
    for (Eigen::Index t = range.begin(); t != range.end(); ++t) {
      const double* a = solved.row(system, triangles(t, 0), buffers.data());
      const double* b = solved.row(system, triangles(t, 1), buffers.data() + k);
      const double* c = solved.row(system, triangles(t, 2), buffers.data() + 2 * k);
      double* out = values.row(t).data();
      for (Eigen::Index j = 0; j < k; ++j) out[j] = (a[j] + b[j] + c[j]) / 3.0;
    }
  });
  return values;
}

}  // namespace hdeform

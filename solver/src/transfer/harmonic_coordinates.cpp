#include "hdeform/harmonic_coordinates.h"

#include <tbb/parallel_for.h>

namespace hdeform {
namespace {

constexpr Eigen::Index kRowGrain = 256;

}  // namespace

VertexCoordinates::VertexCoordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers)
    : row_of_vertex_(system.row_of_vertex()), marker_of_(partition.role.size(), -1) {
  const auto k = static_cast<Eigen::Index>(markers.size());
  columns_ = static_cast<int>(k);
  for (Eigen::Index j = 0; j < k; ++j) marker_of_[static_cast<std::size_t>(markers[static_cast<std::size_t>(j)])] = static_cast<int>(j);
  stray_value_ = 1.0 / static_cast<double>(k);
  // Right-hand side −L_fc X_c, each column summed over the coupling in its order (as
  // DirichletSystem::solve sums it).
  // Rows padded to the solve's fastest stride (the pad stays zero). First written by the threads
  // below: its pages faulted in on both cores.
  free_.resize(system.free_count(), SparseCholesky::fast_solve_stride(columns_));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, system.free_count(), kRowGrain), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index r = range.begin(); r != range.end(); ++r) {
      auto values = free_.row(r);
      values.setZero();
      for (const auto& entry : system.coupling(static_cast<int>(r))) {
        if (const int marker = marker_of_[static_cast<std::size_t>(entry.vertex)]; marker >= 0) {
          values(marker) -= entry.weight;
        } else {
          for (Eigen::Index c = 0; c < k; ++c) values(c) -= entry.weight * stray_value_;
        }
      }
    }
  });
  if (system.free_count() > 0 && k > 0) system.factor().solve_block(free_.data(), columns_, static_cast<int>(free_.cols()));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, system.free_count(), kRowGrain), [&](const tbb::blocked_range<Eigen::Index>& range) {
    auto rows = free_.middleRows(range.begin(), range.size());
    rows = rows.cwiseMax(0.0).cwiseMin(1.0);
  });
}

const double* VertexCoordinates::row(int v, double* buffer) const {
  if (const int r = row_of_vertex_[static_cast<std::size_t>(v)]; r >= 0) return free_.row(r).data();
  const Eigen::Index k = columns_;
  if (const int marker = marker_of_[static_cast<std::size_t>(v)]; marker >= 0) {
    std::fill(buffer, buffer + k, 0.0);
    buffer[marker] = 1.0;
  } else {
    std::fill(buffer, buffer + k, stray_value_);
  }
  return buffer;
}

void VertexCoordinates::triangle_row(const Eigen::MatrixXi& triangles, Eigen::Index t, double* out, double* scratch) const {
  const Eigen::Index k = columns_;
  const double* a = row(triangles(t, 0), scratch);
  const double* b = row(triangles(t, 1), scratch + k);
  const double* c = row(triangles(t, 2), scratch + 2 * k);
  for (Eigen::Index j = 0; j < k; ++j) out[j] = (a[j] + b[j] + c[j]) / 3.0;
}

Eigen::MatrixXd harmonic_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers) {
  const VertexCoordinates coordinates(system, partition, markers);
  Eigen::MatrixXd values(coordinates.vertex_count(), coordinates.columns());
  std::vector<double> buffer(static_cast<std::size_t>(coordinates.columns()));
  for (Eigen::Index v = 0; v < values.rows(); ++v) {
    values.row(v) = Eigen::Map<const Eigen::RowVectorXd>(coordinates.row(static_cast<int>(v), buffer.data()), values.cols());
  }
  return values;
}

CoordinateRows triangle_coordinates(const VertexCoordinates& coordinates, const Eigen::MatrixXi& triangles) {
  CoordinateRows values(triangles.rows(), coordinates.columns());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, triangles.rows(), kRowGrain), [&](const tbb::blocked_range<Eigen::Index>& range) {
    std::vector<double> scratch(3 * static_cast<std::size_t>(coordinates.columns()));
    for (Eigen::Index t = range.begin(); t != range.end(); ++t) coordinates.triangle_row(triangles, t, values.row(t).data(), scratch.data());
  });
  return values;
}

CoordinateRows triangle_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers,
                                    const Eigen::MatrixXi& triangles) {
  return triangle_coordinates(VertexCoordinates(system, partition, markers), triangles);
}

}  // namespace hdeform

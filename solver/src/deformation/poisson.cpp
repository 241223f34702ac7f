#include "hdeform/poisson.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <utility>

namespace hdeform {

PoissonAssembler::PoissonAssembler(const Mesh& rest, const CotangentWeights& weights, const DirichletSystem& system)
    : system_(system) {
  const auto& row_of_vertex = system.row_of_vertex();
  const auto rows = static_cast<std::size_t>(system.free_count());
  auto active = [&](Eigen::Index t) { return weights.kind[static_cast<std::size_t>(t)] != ElementKind::Ignored; };
  // Each row's corners in triangle order. The triangles are cut into chunks, each chunk's corners
  // counted per row, so that every chunk writes its corners where one pass in triangle order puts
  // them: the same array, written on every thread (and its pages first touched there).
  const int chunks = std::max(1, std::min(8, tbb::this_task_arena::max_concurrency()));
  const Eigen::Index per_chunk = (rest.triangle_count() + chunks - 1) / chunks;
  auto chunk_range = [&](int c) { return std::pair(c * per_chunk, std::min(rest.triangle_count(), (c + 1) * per_chunk)); };
  std::vector<std::vector<std::size_t>> at(static_cast<std::size_t>(chunks), std::vector<std::size_t>(rows, 0));
  tbb::parallel_for(0, chunks, [&](int c) {
    auto& count = at[static_cast<std::size_t>(c)];
    for (auto [t, end] = chunk_range(c); t < end; ++t) {
      if (!active(t)) continue;
      for (int k = 0; k < 3; ++k) {
        if (const int row = row_of_vertex[static_cast<std::size_t>(rest.triangles(t, k))]; row >= 0) ++count[static_cast<std::size_t>(row)];
      }
    }
  });
  corner_start_.assign(rows + 1, 0);
  for (std::size_t r = 0; r < rows; ++r) {
    std::size_t next = corner_start_[r];
    for (auto& chunk : at) next += std::exchange(chunk[r], next);  // the chunk's count becomes where it starts
    corner_start_[r + 1] = next;
  }
  corner_triangle_.resize(corner_start_.back());
  corner_gradient_.resize(corner_start_.back());
  tbb::parallel_for(0, chunks, [&](int c) {
    auto& fill = at[static_cast<std::size_t>(c)];
    for (auto [t, end] = chunk_range(c); t < end; ++t) {
      if (!active(t)) continue;
      for (int k = 0; k < 3; ++k) {
        const int row = row_of_vertex[static_cast<std::size_t>(rest.triangles(t, k))];
        if (row < 0) continue;
        // Corner k's edges are opposite corners k+2 (edge k,k+1) and k+1 (edge k,k+2).
        const Eigen::Vector3d p = rest.positions.row(rest.triangles(t, k));
        const Eigen::Vector3d next = rest.positions.row(rest.triangles(t, (k + 1) % 3));
        const Eigen::Vector3d previous = rest.positions.row(rest.triangles(t, (k + 2) % 3));
        const Eigen::Vector3d gradient = weights.half_cotangent(t, (k + 2) % 3) * (p - next) +
                                         weights.half_cotangent(t, (k + 1) % 3) * (p - previous);
        const std::size_t corner = fill[static_cast<std::size_t>(row)]++;
        corner_triangle_[corner].index = static_cast<int>(t);
        corner_gradient_[corner] = gradient;
      }
    }
  });
}

template <class CornerSum>
void PoissonAssembler::assemble_rows(const Eigen::MatrixXd& positions, ColumnBlocks& rhs, int first_column, CornerSum corner_sum) const {
  const auto rows = system_.free_count();
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, rows, 1024), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index row = range.begin(); row != range.end(); ++row) {
      const auto begin = corner_start_[static_cast<std::size_t>(row)];
      const auto end = corner_start_[static_cast<std::size_t>(row) + 1];
      Eigen::Vector3d b = corner_sum(corner_triangle_.data() + begin, corner_gradient_.data() + begin, end - begin);
      for (const auto& entry : system_.coupling(static_cast<int>(row))) {
        b.noalias() -= entry.weight * positions.row(entry.vertex).transpose();
      }
      for (int c = 0; c < 3; ++c) rhs.at(row, first_column + c) = b(c);
    }
  });
}

void PoissonAssembler::assemble(std::span<const Eigen::Matrix3d> maps, const Eigen::MatrixXd& positions, ColumnBlocks& rhs,
                                int first_column) const {
  assemble_rows(positions, rhs, first_column, [&](const CornerTriangle* triangle, const Eigen::Vector3d* gradient, std::size_t count) {
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < count; ++i) b.noalias() += maps[static_cast<std::size_t>(triangle[i].index)] * gradient[i];
    return b;
  });
}

void PoissonAssembler::assemble(const AxialMaps& maps, const Eigen::MatrixXd& positions, ColumnBlocks& rhs, int first_column) const {
  const Eigen::Vector3d& a = maps.axis;
  assemble_rows(positions, rhs, first_column, [&](const CornerTriangle* triangle, const Eigen::Vector3d* gradient, std::size_t count) {
    Eigen::Vector3d along = Eigen::Vector3d::Zero(), turned = Eigen::Vector3d::Zero(), axial = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < count; ++i) {
      const Eigen::Vector3d& c = maps.coefficients[static_cast<std::size_t>(triangle[i].index)];
      along += c(0) * gradient[i];
      turned += c(1) * gradient[i];
      axial += c(2) * gradient[i];
    }
    return Eigen::Vector3d(along + a.cross(turned) + a * a.dot(axial));
  });
}

void poisson_reconstruct(const PoissonAssembler& assembler, const DirichletSystem& system,
                         std::span<const Eigen::Matrix3d> maps, Eigen::MatrixXd& positions) {
  ColumnBlocks rhs(system.free_count(), 3, SolveSchedule::Blocked);
  assembler.assemble(maps, positions, rhs);
  rhs.solve(system.factor());
  for (Eigen::Index row = 0; row < system.free_count(); ++row) {
    for (int c = 0; c < 3; ++c) positions(system.vertex_of_row()[static_cast<std::size_t>(row)], c) = rhs.at(row, c);
  }
}

}  // namespace hdeform

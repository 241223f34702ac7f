#include "hdeform/laplacian.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <numeric>

namespace hdeform {
namespace {

// Marks every triangle that repeats an earlier one (same vertex set, either orientation).
void mark_duplicates(const Eigen::MatrixXi& triangles, std::vector<ElementKind>& kind) {
  const auto m = static_cast<std::size_t>(triangles.rows());
  std::vector<std::array<int, 3>> sorted(m);
  for (std::size_t t = 0; t < m; ++t) {
    sorted[t] = {triangles(static_cast<Eigen::Index>(t), 0), triangles(static_cast<Eigen::Index>(t), 1),
                 triangles(static_cast<Eigen::Index>(t), 2)};
    std::sort(sorted[t].begin(), sorted[t].end());
  }
  std::vector<std::uint32_t> order(m);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return sorted[a] != sorted[b] ? sorted[a] < sorted[b] : a < b;
  });
  for (std::size_t k = 1; k < m; ++k) {
    if (sorted[order[k]] == sorted[order[k - 1]]) kind[order[k]] = ElementKind::Ignored;
  }
}

}  // namespace

std::size_t CotangentWeights::count(ElementKind which) const {
  return static_cast<std::size_t>(std::count(kind.begin(), kind.end(), which));
}

CotangentWeights cotangent_weights(const Mesh& mesh) {
  validate_mesh(mesh);
  const auto m = mesh.triangle_count();
  CotangentWeights weights;
  weights.half_cotangent = Eigen::MatrixXd::Zero(m, 3);
  weights.kind.assign(static_cast<std::size_t>(m), ElementKind::Regular);
  mark_duplicates(mesh.triangles, weights.kind);

  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, m, 4096), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index t = range.begin(); t != range.end(); ++t) {
      auto& kind = weights.kind[static_cast<std::size_t>(t)];
      const int i0 = mesh.triangles(t, 0), i1 = mesh.triangles(t, 1), i2 = mesh.triangles(t, 2);
      if (i0 == i1 || i1 == i2 || i0 == i2) kind = ElementKind::Ignored;
      if (kind == ElementKind::Ignored) continue;
      const Eigen::Vector3d p[3] = {mesh.positions.row(i0), mesh.positions.row(i1), mesh.positions.row(i2)};
      double dot[3];
      double largest_dot = 0.0;
      for (int k = 0; k < 3; ++k) {
        dot[k] = (p[(k + 1) % 3] - p[k]).dot(p[(k + 2) % 3] - p[k]);
        largest_dot = std::max(largest_dot, std::abs(dot[k]));
      }
      const double twice_area = (p[1] - p[0]).cross(p[2] - p[0]).norm();
      if (largest_dot == 0.0) {  // all three corners at one point
        kind = ElementKind::Ignored;
        continue;
      }
      // cot_k = dot_k / (2A); the test below is |cot| ≤ kMaxCotangent without dividing by zero.
      const bool regular = twice_area * kMaxCotangent >= largest_dot;
      const double denominator = regular ? twice_area : largest_dot / kMaxCotangent;
      if (!regular) kind = ElementKind::Degenerate;
      for (int k = 0; k < 3; ++k) weights.half_cotangent(t, k) = 0.5 * dot[k] / denominator;
    }
  });
  return weights;
}

Eigen::SparseMatrix<double> cotangent_laplacian(const Mesh& mesh, const CotangentWeights& weights) {
  const auto n = mesh.vertex_count();
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(static_cast<std::size_t>(mesh.triangle_count()) * 6 + static_cast<std::size_t>(n));
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    if (weights.kind[static_cast<std::size_t>(t)] == ElementKind::Ignored) continue;
    for (int k = 0; k < 3; ++k) {
      const int i = mesh.triangles(t, (k + 1) % 3);
      const int j = mesh.triangles(t, (k + 2) % 3);
      const double w = weights.half_cotangent(t, k);
      entries.emplace_back(i, j, -w);
      entries.emplace_back(j, i, -w);
    }
  }
  // Explicit diagonal entries (filled below) so that every vertex has one, even an isolated one.
  for (Eigen::Index v = 0; v < n; ++v) entries.emplace_back(static_cast<int>(v), static_cast<int>(v), 0.0);
  Eigen::SparseMatrix<double> laplacian(n, n);
  laplacian.setFromTriplets(entries.begin(), entries.end());
  laplacian.makeCompressed();
  // Diagonal = −(sum of the off-diagonals): rows sum to zero exactly, independent of round-off
  // in the per-triangle accumulation.
  for (Eigen::Index col = 0; col < n; ++col) {
    double off_diagonal_sum = 0.0;
    double* diagonal = nullptr;
    for (Eigen::SparseMatrix<double>::InnerIterator it(laplacian, col); it; ++it) {
      if (it.row() == col) diagonal = &it.valueRef();
      else off_diagonal_sum += it.value();
    }
    *diagonal = -off_diagonal_sum;
  }
  return laplacian;
}

Eigen::SparseMatrix<double> cotangent_laplacian(const Mesh& mesh) {
  return cotangent_laplacian(mesh, cotangent_weights(mesh));
}

}  // namespace hdeform

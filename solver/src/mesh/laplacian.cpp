#include "hdeform/laplacian.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <numeric>

namespace hdeform {
namespace {

// Marks every triangle that repeats an earlier one (same vertex set, either orientation).
void mark_duplicates(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count, std::vector<ElementKind>& kind) {
  const auto m = static_cast<std::size_t>(triangles.rows());
  auto sorted_corners = [&](std::size_t t) {
    std::array<int, 3> corners{triangles(static_cast<Eigen::Index>(t), 0), triangles(static_cast<Eigen::Index>(t), 1),
                               triangles(static_cast<Eigen::Index>(t), 2)};
    std::sort(corners.begin(), corners.end());
    return corners;
  };
  if (vertex_count <= (Eigen::Index{1} << 21)) {
    // Three indices below 2^21 make one 63-bit key: a parallel sort of numbers.
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(m);
    tbb::parallel_for(std::size_t{0}, m, [&](std::size_t t) {
      const auto c = sorted_corners(t);
      keys[t] = {(std::uint64_t(std::uint32_t(c[0])) << 42) | (std::uint64_t(std::uint32_t(c[1])) << 21) | std::uint32_t(c[2]),
                 static_cast<std::uint32_t>(t)};
    });
    tbb::parallel_sort(keys.begin(), keys.end());
    for (std::size_t k = 1; k < m; ++k) {
      if (keys[k].first == keys[k - 1].first) kind[keys[k].second] = ElementKind::Ignored;
    }
    return;
  }
  std::vector<std::array<int, 3>> sorted(m);
  for (std::size_t t = 0; t < m; ++t) sorted[t] = sorted_corners(t);
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
  mark_duplicates(mesh.triangles, mesh.vertex_count(), weights.kind);

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
  // Assembled column by column in place of a triplet list: each column's entries are listed in
  // triangle order, then sorted by row (stably) and summed, so that every sum runs in the order
  // a triplet assembly would add it up.
  struct Entry {
    int row;
    double value;
  };
  std::vector<int> start(static_cast<std::size_t>(n) + 1, 1);  // every column holds its diagonal
  auto each_half_edge = [&](auto&& visit) {
    for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
      if (weights.kind[static_cast<std::size_t>(t)] == ElementKind::Ignored) continue;
      for (int k = 0; k < 3; ++k) {
        const int i = mesh.triangles(t, (k + 1) % 3);
        const int j = mesh.triangles(t, (k + 2) % 3);
        const double w = weights.half_cotangent(t, k);
        visit(i, j, -w);
        visit(j, i, -w);
      }
    }
  };
  each_half_edge([&](int row, int col, double) {
    (void)row;
    ++start[static_cast<std::size_t>(col) + 1];
  });
  start[0] = 0;
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<Entry> entries(static_cast<std::size_t>(start.back()));
  std::vector<int> next(start.begin(), start.end() - 1);
  each_half_edge([&](int row, int col, double value) { entries[static_cast<std::size_t>(next[static_cast<std::size_t>(col)]++)] = {row, value}; });
  for (Eigen::Index col = 0; col < n; ++col) entries[static_cast<std::size_t>(next[static_cast<std::size_t>(col)])] = {static_cast<int>(col), 0.0};

  std::vector<int> kept(static_cast<std::size_t>(n));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 2048), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index col = range.begin(); col != range.end(); ++col) {
      Entry* first = entries.data() + start[static_cast<std::size_t>(col)];
      Entry* last = entries.data() + start[static_cast<std::size_t>(col) + 1];
      std::stable_sort(first, last, [](const Entry& a, const Entry& b) { return a.row < b.row; });
      Entry* out = first;
      for (Entry* in = first + 1; in != last; ++in) {
        if (in->row == out->row) out->value += in->value;
        else *++out = *in;
      }
      kept[static_cast<std::size_t>(col)] = static_cast<int>(out - first) + 1;
    }
  });
  Eigen::SparseMatrix<double> laplacian(n, n);  // compressed, no entries yet
  laplacian.resizeNonZeros(std::accumulate(kept.begin(), kept.end(), Eigen::Index{0}));
  int* outer = laplacian.outerIndexPtr();
  outer[0] = 0;
  for (Eigen::Index col = 0; col < n; ++col) outer[col + 1] = outer[col] + kept[static_cast<std::size_t>(col)];
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 2048), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index col = range.begin(); col != range.end(); ++col) {
      const Entry* first = entries.data() + start[static_cast<std::size_t>(col)];
      double off_diagonal_sum = 0.0;
      int diagonal = -1;
      for (int k = 0; k < kept[static_cast<std::size_t>(col)]; ++k) {
        const int slot = outer[col] + k;
        laplacian.innerIndexPtr()[slot] = first[k].row;
        laplacian.valuePtr()[slot] = first[k].value;
        if (first[k].row == col) diagonal = slot;
        else off_diagonal_sum += first[k].value;
      }
      // Diagonal = −(sum of the off-diagonals): rows sum to zero exactly, independent of
      // round-off in the per-triangle accumulation.
      laplacian.valuePtr()[diagonal] = -off_diagonal_sum;
    }
  });
  return laplacian;
}

Eigen::SparseMatrix<double> cotangent_laplacian(const Mesh& mesh) {
  return cotangent_laplacian(mesh, cotangent_weights(mesh));
}

}  // namespace hdeform

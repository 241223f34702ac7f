#include "hdeform/shape_metrics.h"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace hdeform {

double mean_edge_strain(const Mesh& rest, const Eigen::MatrixXd& deformed) {
  if (deformed.rows() != rest.vertex_count() || deformed.cols() != 3) {
    throw std::invalid_argument("mean_edge_strain: the deformed positions do not match the rest mesh");
  }
  std::vector<std::uint64_t> edges;
  edges.reserve(static_cast<std::size_t>(rest.triangle_count()) * 3);
  for (Eigen::Index t = 0; t < rest.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<std::uint32_t>(rest.triangles(t, k));
      const auto b = static_cast<std::uint32_t>(rest.triangles(t, (k + 1) % 3));
      if (a != b) edges.push_back((static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  double sum = 0.0;
  std::size_t counted = 0;
  for (const auto edge : edges) {
    const auto a = static_cast<Eigen::Index>(edge >> 32), b = static_cast<Eigen::Index>(edge & 0xffffffffu);
    const double length = (rest.positions.row(a) - rest.positions.row(b)).norm();
    if (!(length > 0.0)) continue;
    sum += std::abs((deformed.row(a) - deformed.row(b)).norm() / length - 1.0);
    ++counted;
  }
  return counted == 0 ? 0.0 : sum / static_cast<double>(counted);
}

}  // namespace hdeform

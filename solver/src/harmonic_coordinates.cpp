#include "hdeform/harmonic_coordinates.h"

namespace hdeform {

Eigen::MatrixXd harmonic_coordinates(const DirichletSystem& system, const VertexPartition& partition, std::span<const int> markers) {
  const auto n = static_cast<Eigen::Index>(partition.role.size());
  const auto k = static_cast<Eigen::Index>(markers.size());
  Eigen::MatrixXd values = Eigen::MatrixXd::Zero(n, k);
  for (Eigen::Index v = 0; v < n; ++v) {
    if (partition.role[static_cast<std::size_t>(v)] != VertexRole::Free) values.row(v).setConstant(1.0 / static_cast<double>(k));
  }
  for (Eigen::Index j = 0; j < k; ++j) {
    values.row(markers[static_cast<std::size_t>(j)]).setZero();
    values(markers[static_cast<std::size_t>(j)], j) = 1.0;
  }
  system.solve(values);
  values = values.cwiseMax(0.0).cwiseMin(1.0);  // in place: coefficient-wise, no temporary
  return values;
}

}  // namespace hdeform

#include "hdeform/harmonic_field.h"

namespace hdeform {

Eigen::VectorXd harmonic_field(const DirichletSystem& system, const VertexPartition& partition) {
  Eigen::MatrixXd values = Eigen::MatrixXd::Zero(system.vertex_count(), 1);
  for (std::size_t v = 0; v < partition.role.size(); ++v) {
    if (partition.role[v] == VertexRole::Handle) values(static_cast<Eigen::Index>(v), 0) = 1.0;
  }
  system.solve(values);
  return values.col(0).cwiseMax(0.0).cwiseMin(1.0);
}

}  // namespace hdeform

#include "hdeform/mesh.h"

namespace hdeform {

double bounding_box_diagonal(const Eigen::MatrixXd& positions) {
  if (positions.rows() == 0) return 0.0;
  return (positions.colwise().maxCoeff() - positions.colwise().minCoeff()).norm();
}

}  // namespace hdeform

#include "gui/gizmo.h"

#include <Eigen/Geometry>
#include <cmath>

namespace hdeform::cli {

void compose_rotation(Eigen::Vector3d& axis, double& angle, const Eigen::Vector3d& delta_axis, double delta_angle) {
  const Eigen::Vector3d turn = delta_axis.normalized();
  const double alignment = turn.dot(axis);
  if (std::abs(alignment) > 1.0 - 1e-9 || angle == 0.0) {
    // About the same line (or from no rotation): angles add, whole turns kept.
    if (angle == 0.0) axis = turn;
    angle += alignment < 0.0 && angle != 0.0 ? -delta_angle : delta_angle;
    return;
  }
  const Eigen::AngleAxisd composed(Eigen::AngleAxisd(delta_angle, turn) * Eigen::AngleAxisd(angle, axis));
  angle = composed.angle();
  axis = angle == 0.0 ? axis : Eigen::Vector3d(composed.axis());
}

}  // namespace hdeform::cli

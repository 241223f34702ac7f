#pragma once
// The rotation arithmetic of the handle gizmo. A pose is an axis and an angle of any size; turns
// about the pose's own axis add up, so a twist keeps its turns, and any other rotation composes
// into a single rotation with its angle in [0, π].
#include <Eigen/Core>

namespace hdeform::cli {

void compose_rotation(Eigen::Vector3d& axis, double& angle, const Eigen::Vector3d& delta_axis, double delta_angle);

}  // namespace hdeform::cli

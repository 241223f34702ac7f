#include "gui/handle_drag.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hdeform::cli {
namespace {

Eigen::Vector3d twist_direction(TwistAxis axis, const Eigen::Vector3f& forward) {
  switch (axis) {
    case TwistAxis::X: return Eigen::Vector3d::UnitX();
    case TwistAxis::Y: return Eigen::Vector3d::UnitY();
    case TwistAxis::Z: return Eigen::Vector3d::UnitZ();
    case TwistAxis::View: return (-forward).cast<double>();
  }
  return Eigen::Vector3d::UnitZ();
}

}  // namespace

HandleTransform drag_pose(const HandleTransform& pose, const EditTools& tools, GizmoPart part, const DragStep& step) {
  Eigen::Vector3d axis = pose.axis;
  double angle = pose.angle;
  double scale = pose.scale;
  Eigen::Vector3d shift = pose.shift;
  const Eigen::Vector3f centre = (pose.pivot + pose.shift).cast<float>();
  // The constraint: a part of the gizmo (the handle's own axes), else the lock (world axes).
  std::optional<Eigen::Vector3f> along, normal, about;
  if (part != GizmoPart::None) {
    const Eigen::Vector3f axis_k = pose.rotation().toRotationMatrix().cast<float>().col(gizmo_axis(part));
    if (is_ring(part)) about = axis_k;
    else if (is_plane(part)) normal = axis_k;
    else along = axis_k;
  } else if (tools.axis_lock) {
    const Eigen::Vector3f axis_k = Eigen::Vector3f::Unit(*tools.axis_lock);
    if (tools.tool == Tool::Rotate) about = axis_k;
    else if (tools.lock_plane) normal = axis_k;
    else along = axis_k;
  }
  switch (tools.tool) {
    case Tool::Grab:
      if (along) shift += drag_along_axis(step.from, step.to, centre, *along).cast<double>();
      else if (normal) shift += drag_in_plane(step.from, step.to, centre, *normal).cast<double>();
      else shift += (step.world_per_pixel * (step.delta.x() * step.right - step.delta.y() * step.up)).cast<double>();
      break;
    case Tool::Rotate: {
      if (about) {
        // Seen nearly edge-on, a ring's plane gives no stable intersection: follow its near side.
        const double turn = std::abs(step.forward.dot(*about)) >= 0.3f
                                ? drag_about_axis(step.from, step.to, centre, *about)
                                : drag_about_axis_edge_on(step.delta, centre, *about, step.ring_radius, -step.forward, step.project);
        compose_rotation(axis, angle, about->cast<double>(), turn);
        break;
      }
      // About the view axis, following the cursor around the handle's centre on screen.
      const auto pivot = step.project(centre);
      if (!pivot) break;
      const Eigen::Vector2f before = step.cursor - step.delta - *pivot, after = step.cursor - *pivot;
      double turn = std::atan2(after.y(), after.x()) - std::atan2(before.y(), before.x());
      turn -= 2.0 * std::numbers::pi * std::round(turn / (2.0 * std::numbers::pi));
      compose_rotation(axis, angle, (-step.forward).cast<double>(), -turn);  // clockwise on screen (y down) is clockwise seen
      break;
    }
    // Up or right grows it (100 pixels: a factor e), down or left shrinks it.
    case Tool::Scale: scale = std::clamp(scale * std::exp(0.01 * (step.delta.x() - step.delta.y())), 0.05, 20.0); break;
    case Tool::Twist: compose_rotation(axis, angle, twist_direction(tools.twist_axis, step.forward), 0.01 * step.delta.x()); break;
    default: return pose;
  }
  return HandleTransform::about_pivot(axis, pose.pivot, angle, scale, shift);
}

}  // namespace hdeform::cli

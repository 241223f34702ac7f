#pragma once
// What a mouse drag does to the active handle's pose, free of any window: the move, rotate,
// scale and twist tools, each constrained by the gizmo part the drag started on or by the axis
// lock, else free in the view.
#include <functional>
#include <optional>

#include "gui/edit_tools.h"
#include "gui/gizmo.h"
#include "hdeform/handle_transform.h"

namespace hdeform::cli {

// One step of the drag, as the view saw it.
struct DragStep {
  Ray from, to;                 // the cursor's rays before and after the step
  Eigen::Vector2f cursor;       // after, in window pixels (y down)
  Eigen::Vector2f delta;        // the step in window pixels
  Eigen::Vector3f forward, right, up;  // the camera's unit axes (right × forward = up)
  float world_per_pixel = 1.0f;  // at the handle's depth: a free move's scale
  std::function<std::optional<Eigen::Vector2f>(const Eigen::Vector3f&)> project;  // to window pixels
  float ring_radius = 1.0f;     // the rotate gizmo's rings, in world units
};

// The pose after `step` of a drag with `tools` (its tool, twist axis and lock) that started on
// `part` of the gizmo (None: anywhere else). Paint tools leave the pose as it is.
HandleTransform drag_pose(const HandleTransform& pose, const EditTools& tools, GizmoPart part, const DragStep& step);

}  // namespace hdeform::cli

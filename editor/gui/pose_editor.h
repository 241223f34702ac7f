#pragma once
// The panel's fields for the active handle's pose: Move, Axis, Angle° (any number of turns) and
// Scale, each typed (double click, or Ctrl+click) or dragged.
#include <Eigen/Core>

namespace hdeform::cli {

struct PoseFields {
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  double degrees = 0.0;
  double scale = 1.0;
};

struct PoseFieldsEdit {
  bool changed = false;   // a value changed this frame: apply it now, so the mesh follows
  bool finished = false;  // an edit of one of the fields ended (Enter, a click elsewhere, the
                          // end of a drag): one undo step
};

// Draws the fields; `move_step` is the Move field's change per pixel dragged. An axis of zero
// length is refused (the previous axis stays); the axis is kept unit length; the scale stays in
// [0.05, 20].
PoseFieldsEdit pose_fields(PoseFields& fields, float move_step);

}  // namespace hdeform::cli

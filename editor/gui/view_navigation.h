#pragma once
// How the mouse moves a view's camera, the same in both editor modes: right drag (or Alt+left
// drag) orbits, middle drag (or Shift+right drag) pans, the wheel zooms.
#include <Eigen/Core>

#include "hdeform/engine/camera.h"

namespace hdeform::cli {

enum class CameraGesture { None, Orbit, Pan };

CameraGesture camera_gesture(bool left, bool middle, bool right, bool shift, bool alt);
// The gesture of the mouse buttons and modifiers held this frame (Dear ImGui's state).
CameraGesture camera_gesture_now();

// One frame of a gesture: the cursor moved `delta` window pixels in a view `view_height` window
// pixels tall, and the wheel turned `wheel` notches.
void apply_camera_gesture(engine::Camera& camera, CameraGesture gesture, const Eigen::Vector2f& delta, float view_height, float wheel);

}  // namespace hdeform::cli

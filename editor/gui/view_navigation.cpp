#include "gui/view_navigation.h"

#include <imgui.h>

#include <algorithm>
#include <cmath>

namespace hdeform::cli {
namespace {

constexpr float kOrbitPerPixel = 0.008f;  // radians
constexpr float kZoomPerNotch = 0.88f;

}  // namespace

CameraGesture camera_gesture(bool left, bool middle, bool right, bool shift, bool alt) {
  if (middle || (shift && right)) return CameraGesture::Pan;
  if (right || (alt && left)) return CameraGesture::Orbit;
  return CameraGesture::None;
}

CameraGesture camera_gesture_now() {
  const ImGuiIO& io = ImGui::GetIO();
  return camera_gesture(ImGui::IsMouseDown(ImGuiMouseButton_Left), ImGui::IsMouseDown(ImGuiMouseButton_Middle), ImGui::IsMouseDown(ImGuiMouseButton_Right),
                        io.KeyShift, io.KeyAlt);
}

void apply_camera_gesture(engine::Camera& camera, CameraGesture gesture, const Eigen::Vector2f& delta, float view_height, float wheel) {
  const float height = std::max(view_height, 1.0f);
  if (gesture == CameraGesture::Pan) camera.pan(-delta.x() / height, delta.y() / height);
  if (gesture == CameraGesture::Orbit) camera.orbit(-delta.x() * kOrbitPerPixel, delta.y() * kOrbitPerPixel);
  if (wheel != 0.0f) camera.zoom(std::pow(kZoomPerNotch, wheel));
}

}  // namespace hdeform::cli

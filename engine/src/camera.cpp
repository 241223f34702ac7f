#include "hdeform/engine/camera.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hdeform::engine {
namespace {

constexpr float kMaxPitch = 1.55f;  // just short of straight up or down

}  // namespace

UpAxis guess_up_axis(const Eigen::MatrixXd& positions) {
  if (positions.rows() == 0) return UpAxis::Z;
  const Eigen::RowVector3d lowest = positions.colwise().minCoeff();
  const Eigen::RowVector3d extent = positions.colwise().maxCoeff() - lowest;
  const double reach = 0.02 * extent.norm();
  const auto standing = [&](int axis) {
    Eigen::RowVector3d low = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity()), high = -low;
    Eigen::Index count = 0;
    for (Eigen::Index v = 0; v < positions.rows(); ++v) {
      if (positions(v, axis) - lowest(axis) > reach) continue;
      low = low.cwiseMin(positions.row(v));
      high = high.cwiseMax(positions.row(v));
      ++count;
    }
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const double footprint = extent(a) * extent(b) > 0.0 ? (high(a) - low(a)) * (high(b) - low(b)) / (extent(a) * extent(b)) : 0.0;
    return static_cast<double>(count) / static_cast<double>(positions.rows()) * footprint;
  };
  return standing(1) > standing(2) ? UpAxis::Y : UpAxis::Z;
}

Bounds Bounds::of(const Eigen::MatrixXd& positions) {
  Bounds bounds;
  if (positions.rows() == 0) return bounds;
  bounds.min = positions.colwise().minCoeff().transpose().cast<float>();
  bounds.max = positions.colwise().maxCoeff().transpose().cast<float>();
  return bounds;
}

Camera Camera::three_quarter_front(const Bounds& bounds, UpAxis up, float aspect, float covered_left) {
  Camera camera;
  camera.up = up;
  camera.covered_left = covered_left;
  camera.yaw = 0.55f;    // about 30° round from the front
  camera.pitch = 0.30f;  // about 17° above
  camera.fit(bounds, aspect);
  return camera;
}

void Camera::fit(const Bounds& bounds, float aspect) {
  target = bounds.center();
  scene_radius = std::max(bounds.radius(), 1e-6f);
  const float visible_aspect = aspect * (1.0f - std::clamp(covered_left, 0.0f, 0.9f));
  const float half_fov = 0.5f * std::min(fov_y, 2.0f * std::atan(std::tan(0.5f * fov_y) * visible_aspect));
  distance = 1.08f * scene_radius / std::sin(half_fov);
}

void Camera::orbit(float delta_yaw, float delta_pitch) {
  yaw += delta_yaw;
  pitch = std::clamp(pitch + delta_pitch, -kMaxPitch, kMaxPitch);
}

void Camera::pan(float right, float up_amount) {
  const Eigen::Vector3f forward = (target - position()).normalized();
  const Eigen::Vector3f side = forward.cross(up_vector()).normalized();
  const Eigen::Vector3f camera_up = side.cross(forward);
  const float view_height = 2.0f * distance * std::tan(0.5f * fov_y);
  target += view_height * (right * side + up_amount * camera_up);
}

void Camera::zoom(float factor) { distance = std::clamp(distance * factor, 1e-4f * scene_radius, 1e3f * scene_radius); }

Eigen::Vector3f Camera::up_vector() const { return up == UpAxis::Z ? Eigen::Vector3f::UnitZ() : Eigen::Vector3f::UnitY(); }

Eigen::Vector3f Camera::position() const {
  // Front is +x for z-up, +z for y-up; yaw turns towards the right-hand side (+y resp. +x).
  const Eigen::Vector3f front = up == UpAxis::Z ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitZ();
  const Eigen::Vector3f side = up_vector().cross(front);
  const Eigen::Vector3f direction =
      std::cos(pitch) * (std::cos(yaw) * front + std::sin(yaw) * side) + std::sin(pitch) * up_vector();
  return target + distance * direction;
}

Eigen::Matrix4f Camera::view() const {
  const Eigen::Vector3f eye = position();
  const Eigen::Vector3f forward = (target - eye).normalized();
  const Eigen::Vector3f right = forward.cross(up_vector()).normalized();
  const Eigen::Vector3f camera_up = right.cross(forward);
  Eigen::Matrix4f view = Eigen::Matrix4f::Identity();
  view.block<1, 3>(0, 0) = right.transpose();
  view.block<1, 3>(1, 0) = camera_up.transpose();
  view.block<1, 3>(2, 0) = -forward.transpose();
  view(0, 3) = -right.dot(eye);
  view(1, 3) = -camera_up.dot(eye);
  view(2, 3) = forward.dot(eye);
  return view;
}

Eigen::Matrix4f Camera::projection(float aspect) const {
  const float near_plane = std::max(distance - 2.5f * scene_radius, 1e-3f * scene_radius);
  const float far_plane = distance + 4.0f * scene_radius;
  const float f = 1.0f / std::tan(0.5f * fov_y);
  Eigen::Matrix4f projection = Eigen::Matrix4f::Zero();
  projection(0, 0) = f / aspect;
  projection(0, 2) = -covered_left;  // the view's centre moves right by covered_left in x ∈ [-1, 1]
  projection(1, 1) = -f;  // Vulkan: y down
  projection(2, 2) = far_plane / (near_plane - far_plane);
  projection(2, 3) = near_plane * far_plane / (near_plane - far_plane);
  projection(3, 2) = -1.0f;
  return projection;
}

Eigen::ParametrizedLine<float, 3> Camera::ray(float x, float y, float width, float height) const {
  const Eigen::Vector3f eye = position();
  const Eigen::Vector3f forward = (target - eye).normalized();
  const Eigen::Vector3f right = forward.cross(up_vector()).normalized();
  const Eigen::Vector3f camera_up = right.cross(forward);
  const float tan_half = std::tan(0.5f * fov_y);
  const float ndc_x = 2.0f * (x + 0.5f) / width - 1.0f - covered_left;
  const float ndc_y = 1.0f - 2.0f * (y + 0.5f) / height;
  const Eigen::Vector3f direction = forward + ndc_x * tan_half * (width / height) * right + ndc_y * tan_half * camera_up;
  return {eye, direction.normalized()};
}

}  // namespace hdeform::engine

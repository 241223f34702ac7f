#pragma once
/// @file
/// An orbit camera: it looks at a target from a distance, turned by yaw about the up axis and
/// pitched above the horizon. Vulkan conventions: clip y points down, depth in [0, 1].
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hdeform::engine {

/// An axis-aligned bounding box.
struct Bounds {
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();
  /// The box's centre.
  Eigen::Vector3f center() const { return 0.5f * (min + max); }
  /// Half the box's diagonal.
  float radius() const { return 0.5f * (max - min).norm(); }
  /// The box around n×3 positions.
  static Bounds of(const Eigen::MatrixXd& positions);
};

/// The axis a mesh stands up along.
enum class UpAxis { Y, Z };

/// The up axis a mesh was most likely modelled with, of y (the OBJ habit) and z: the one it stands
/// on. For each, the vertices within 2% of the bounding box's diagonal of the lowest plane (hooves,
/// paws, a base) score their share of all vertices times how much of the mesh's footprint across
/// the other two axes they span; Z unless Y scores more. Right for the animals of the transfer
/// data (y) and for the Buddha and the cactus (z); a tube is ambiguous (standing, its bottom ring
/// touches the plane; lying, a line along its side does) and comes out lying.
UpAxis guess_up_axis(const Eigen::MatrixXd& positions);

/// An orbit camera: a target, a distance, yaw about the up axis and pitch above the horizon.
struct Camera {
  Eigen::Vector3f target = Eigen::Vector3f::Zero();
  float distance = 3.0f;
  float yaw = 0.0f;    ///< radians about the up axis; 0 looks from the front (+x for z-up, +z for y-up)
  float pitch = 0.0f;  ///< radians above the horizon
  float fov_y = 0.61f; ///< 35°
  float scene_radius = 1.0f;
  UpAxis up = UpAxis::Z;
  /// The fraction of the view's width, from its left edge, that something else covers (the
  /// editor's side panel): the target is drawn in the middle of the rest, and fit() frames the
  /// bounds there.
  float covered_left = 0.0f;

  /// The default view: the bounds fill the view (what `covered_left` leaves of it), seen from a
  /// three-quarter front angle, slightly from above.
  static Camera three_quarter_front(const Bounds& bounds, UpAxis up, float aspect, float covered_left = 0.0f);
  /// Keeps the angles, moves target and distance so that the bounds fill the uncovered view.
  void fit(const Bounds& bounds, float aspect);

  /// Turns the camera about its target by these radians (pitch kept short of the poles).
  void orbit(float delta_yaw, float delta_pitch);
  /// Moves the target in the view plane by a fraction of the view's height.
  void pan(float right, float up_amount);
  void zoom(float factor);  ///< distance *= factor

  /// The world's up direction for this camera's up axis.
  Eigen::Vector3f up_vector() const;
  /// Where the camera is, in world coordinates.
  Eigen::Vector3f position() const;
  /// The view matrix (world to camera).
  Eigen::Matrix4f view() const;
  /// The perspective projection for a viewport of this width / height (Vulkan clip space).
  Eigen::Matrix4f projection(float aspect) const;
  /// projection(aspect) · view().
  Eigen::Matrix4f view_projection(float aspect) const { return projection(aspect) * view(); }
  /// The world-space ray through a pixel (x right, y down, in pixels of a width×height view).
  Eigen::ParametrizedLine<float, 3> ray(float x, float y, float width, float height) const;
};

}  // namespace hdeform::engine

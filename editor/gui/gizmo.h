#pragma once
// The handle gizmo: three axes (the handle's own, turned by its rotation) with a square per
// plane for moving, or three rings for rotating, about the handle's pivot. A press on a part
// constrains the drag to it: an axis moves along that axis only, a square within its plane, a
// ring turns about its axis. The arithmetic is here, free of any window; the editor projects,
// draws (under its dialogs) and applies the result.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <functional>
#include <optional>
#include <vector>

struct ImDrawList;

namespace hdeform::cli {

using Ray = Eigen::ParametrizedLine<float, 3>;

// A pose is an axis and an angle of any size; turns about the pose's own axis add up, so a twist
// keeps its turns, and any other rotation composes into a single rotation with its angle in [0, π].
void compose_rotation(Eigen::Vector3d& axis, double& angle, const Eigen::Vector3d& delta_axis, double delta_angle);

// The displacement along `axis` (unit) through `origin` that follows a cursor ray moving from
// `from` to `to`: the change of the axis point nearest the ray. Zero while the axis points
// (nearly) along the view ray, where it is ill-defined.
Eigen::Vector3f drag_along_axis(const Ray& from, const Ray& to, const Eigen::Vector3f& origin, const Eigen::Vector3f& axis);
// The displacement within the plane through `origin` normal to `normal` (unit): the change of
// the ray's intersection with it. Zero while the plane is (nearly) edge-on.
Eigen::Vector3f drag_in_plane(const Ray& from, const Ray& to, const Eigen::Vector3f& origin, const Eigen::Vector3f& normal);
// The turn about `axis` (unit) through `centre`, in radians (right-handed), that follows the
// cursor: the angle between the two rays' intersections with the plane normal to the axis.
double drag_about_axis(const Ray& from, const Ray& to, const Eigen::Vector3f& centre, const Eigen::Vector3f& axis);

// The same for a ring seen nearly edge-on, where the plane's intersections jump: the turn that
// makes the ring's point nearest the viewer (at `radius` from the centre) follow the cursor's move
// `delta` (window pixels) along that point's on-screen path. `project` maps to window pixels.
double drag_about_axis_edge_on(const Eigen::Vector2f& delta, const Eigen::Vector3f& centre, const Eigen::Vector3f& axis, float radius,
                               const Eigen::Vector3f& towards_viewer,
                               const std::function<std::optional<Eigen::Vector2f>(const Eigen::Vector3f&)>& project);

enum class GizmoPart { None, AxisX, AxisY, AxisZ, PlaneYZ, PlaneZX, PlaneXY, RingX, RingY, RingZ };
enum class GizmoMode { Move, Rotate };

// The axis index (0–2) of a part: the axis itself, the normal of a plane, the axis of a ring.
int gizmo_axis(GizmoPart part);
bool is_plane(GizmoPart part);
bool is_ring(GizmoPart part);

class HandleGizmo {
 public:
  using Project = std::function<std::optional<Eigen::Vector2f>(const Eigen::Vector3f&)>;  // window pixels, or behind the camera

  // Lays the gizmo out for a frame: at `centre`, along the columns of `axes` (unit), `length`
  // world units long, shortened (to a third at most) until it lies inside [view_min, view_max].
  void layout(const Project& project, const Eigen::Vector3f& centre, const Eigen::Matrix3f& axes, float length, GizmoMode mode,
              const Eigen::Vector2f& view_min, const Eigen::Vector2f& view_max);
  // The part within a few pixels of the cursor (the nearest), or None.
  GizmoPart hit(const Eigen::Vector2f& cursor) const;
  // Draws it (ImGui), the `highlighted` part brighter.
  void draw(ImDrawList* list, GizmoPart highlighted) const;

  const Eigen::Vector3f& centre() const { return centre_; }
  Eigen::Vector3f axis(int k) const { return axes_.col(k); }
  float length() const { return length_; }
  bool laid_out() const { return laid_out_; }

 private:
  static constexpr int kRingSegments = 64;
  bool laid_out_ = false;
  GizmoMode mode_ = GizmoMode::Move;
  Eigen::Vector3f centre_ = Eigen::Vector3f::Zero();
  Eigen::Matrix3f axes_ = Eigen::Matrix3f::Identity();
  float length_ = 1.0f;
  Eigen::Vector2f centre_px_ = Eigen::Vector2f::Zero();
  std::array<Eigen::Vector2f, 3> tips_px_{};
  std::array<std::array<Eigen::Vector2f, 4>, 3> squares_px_{};  // per plane (by normal), its corners
  std::array<std::vector<Eigen::Vector2f>, 3> rings_px_{};       // per axis, a closed polyline
};

}  // namespace hdeform::cli

#include "gui/gizmo.h"

#include <imgui.h>

#include <cmath>
#include <numbers>

namespace hdeform::cli {
namespace {

constexpr float kPickPixels = 8.0f;
constexpr float kMinimumPixels = 10.0f;  // parts seen smaller than this are not targets
constexpr float kPlaneFrom = 0.25f, kPlaneTo = 0.45f;  // a plane's square, as fractions of the length

float distance_to_segment(const Eigen::Vector2f& p, const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
  const Eigen::Vector2f ab = b - a;
  const float t = ab.squaredNorm() > 0.0f ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0f, 1.0f) : 0.0f;
  return (a + t * ab - p).norm();
}

bool inside_quad(const Eigen::Vector2f& p, const std::array<Eigen::Vector2f, 4>& quad) {
  bool in = false;
  for (std::size_t i = 0, j = 3; i < 4; j = i++) {
    const auto& a = quad[i];
    const auto& b = quad[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) in = !in;
  }
  return in;
}

std::optional<Eigen::Vector3f> intersect_plane(const Ray& ray, const Eigen::Vector3f& origin, const Eigen::Vector3f& normal) {
  const float facing = ray.direction().dot(normal);
  if (std::abs(facing) < 1e-3f) return std::nullopt;
  const float s = (origin - ray.origin()).dot(normal) / facing;
  if (s <= 0.0f) return std::nullopt;
  return ray.pointAt(s);
}

std::optional<float> nearest_axis_parameter(const Ray& ray, const Eigen::Vector3f& origin, const Eigen::Vector3f& axis) {
  const Eigen::Vector3f& d = ray.direction();
  const Eigen::Vector3f w = origin - ray.origin();
  const float ad = axis.dot(d), dd = d.dot(d), aa = axis.dot(axis);
  const float denominator = aa * dd - ad * ad;
  if (denominator < 0.02f * aa * dd) return std::nullopt;  // within 8° of the ray: the axis is seen end-on
  return (ad * d.dot(w) - dd * axis.dot(w)) / denominator;
}

}  // namespace

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

Eigen::Vector3f drag_along_axis(const Ray& from, const Ray& to, const Eigen::Vector3f& origin, const Eigen::Vector3f& axis) {
  const auto before = nearest_axis_parameter(from, origin, axis);
  const auto after = nearest_axis_parameter(to, origin, axis);
  if (!before || !after) return Eigen::Vector3f::Zero();
  return (*after - *before) * axis;
}

Eigen::Vector3f drag_in_plane(const Ray& from, const Ray& to, const Eigen::Vector3f& origin, const Eigen::Vector3f& normal) {
  const auto before = intersect_plane(from, origin, normal);
  const auto after = intersect_plane(to, origin, normal);
  if (!before || !after) return Eigen::Vector3f::Zero();
  const Eigen::Vector3f move = *after - *before;
  return move - move.dot(normal) * normal;  // exactly in the plane
}

double drag_about_axis(const Ray& from, const Ray& to, const Eigen::Vector3f& centre, const Eigen::Vector3f& axis) {
  const auto before = intersect_plane(from, centre, axis);
  const auto after = intersect_plane(to, centre, axis);
  if (!before || !after) return 0.0;
  const Eigen::Vector3f a = *before - centre, b = *after - centre;
  if (a.norm() < 1e-9f || b.norm() < 1e-9f) return 0.0;
  return std::atan2(static_cast<double>(axis.dot(a.cross(b))), static_cast<double>(a.dot(b)));
}

double drag_about_axis_edge_on(const Eigen::Vector2f& delta, const Eigen::Vector3f& centre, const Eigen::Vector3f& axis, float radius,
                               const Eigen::Vector3f& towards_viewer,
                               const std::function<std::optional<Eigen::Vector2f>(const Eigen::Vector3f&)>& project) {
  Eigen::Vector3f near = towards_viewer - towards_viewer.dot(axis) * axis;
  if (near.norm() < 1e-6f) return 0.0;  // the axis points at the viewer: not edge-on
  near.normalize();
  const Eigen::Vector3f point = centre + radius * near;
  constexpr float kStep = 0.01f;  // radians
  const auto at = project(point);
  const auto turned = project(centre + radius * (std::cos(kStep) * near + std::sin(kStep) * axis.cross(near)));
  if (!at || !turned) return 0.0;
  const Eigen::Vector2f per_radian = (*turned - *at) / kStep;
  if (per_radian.squaredNorm() < 1e-6f) return 0.0;
  return static_cast<double>(delta.dot(per_radian) / per_radian.squaredNorm());
}

int gizmo_axis(GizmoPart part) {
  switch (part) {
    case GizmoPart::AxisX: case GizmoPart::PlaneYZ: case GizmoPart::RingX: return 0;
    case GizmoPart::AxisY: case GizmoPart::PlaneZX: case GizmoPart::RingY: return 1;
    case GizmoPart::AxisZ: case GizmoPart::PlaneXY: case GizmoPart::RingZ: return 2;
    case GizmoPart::None: break;
  }
  return -1;
}
bool is_plane(GizmoPart part) { return part == GizmoPart::PlaneYZ || part == GizmoPart::PlaneZX || part == GizmoPart::PlaneXY; }
bool is_ring(GizmoPart part) { return part == GizmoPart::RingX || part == GizmoPart::RingY || part == GizmoPart::RingZ; }

void HandleGizmo::layout(const Project& project, const Eigen::Vector3f& centre, const Eigen::Matrix3f& axes, float length, GizmoMode mode,
                         const Eigen::Vector2f& view_min, const Eigen::Vector2f& view_max) {
  laid_out_ = false;
  mode_ = mode;
  centre_ = centre;
  axes_ = axes;
  const auto centre_px = project(centre);
  if (!centre_px) return;
  centre_px_ = *centre_px;
  const auto inside = [&](const Eigen::Vector2f& p) { return (p.array() >= view_min.array()).all() && (p.array() <= view_max.array()).all(); };
  // Shorten until every point drawn is in the view (a third of the length at least).
  for (float fraction = 1.0f; fraction >= 0.33f; fraction *= 0.85f) {
    length_ = length * fraction;
    bool all_inside = true;
    for (int k = 0; k < 3; ++k) {
      const int u = (k + 1) % 3, v = (k + 2) % 3;
      if (mode == GizmoMode::Move) {
        const auto tip = project(centre + length_ * axes.col(k));
        if (!tip) return;
        tips_px_[static_cast<std::size_t>(k)] = *tip;
        all_inside &= inside(*tip);
        // The square of the plane normal to k, spanned by u and v.
        const float corners[4][2] = {{kPlaneFrom, kPlaneFrom}, {kPlaneTo, kPlaneFrom}, {kPlaneTo, kPlaneTo}, {kPlaneFrom, kPlaneTo}};
        for (std::size_t c = 0; c < 4; ++c) {
          const auto p = project(centre + length_ * (corners[c][0] * axes.col(u) + corners[c][1] * axes.col(v)));
          if (!p) return;
          squares_px_[static_cast<std::size_t>(k)][c] = *p;
        }
      } else {
        auto& ring = rings_px_[static_cast<std::size_t>(k)];
        ring.clear();
        for (int s = 0; s < kRingSegments; ++s) {
          const float a = 2.0f * std::numbers::pi_v<float> * static_cast<float>(s) / kRingSegments;
          const auto p = project(centre + 0.8f * length_ * (std::cos(a) * axes.col(u) + std::sin(a) * axes.col(v)));
          if (!p) return;
          ring.push_back(*p);
          all_inside &= inside(*p);
        }
      }
    }
    if (all_inside) break;
  }
  laid_out_ = true;
}

GizmoPart HandleGizmo::hit(const Eigen::Vector2f& cursor) const {
  if (!laid_out_) return GizmoPart::None;
  GizmoPart best = GizmoPart::None;
  float best_distance = kPickPixels;
  if (mode_ == GizmoMode::Move) {
    // A square wins over the axes it touches: it is the smaller target.
    constexpr GizmoPart planes[3] = {GizmoPart::PlaneYZ, GizmoPart::PlaneZX, GizmoPart::PlaneXY};
    for (int k = 0; k < 3; ++k) {
      const auto& square = squares_px_[static_cast<std::size_t>(k)];
      const float area = std::abs((square[2] - square[0]).x() * (square[3] - square[1]).y() - (square[2] - square[0]).y() * (square[3] - square[1]).x());
      if (area >= kMinimumPixels * kMinimumPixels && inside_quad(cursor, square)) return planes[k];  // edge-on squares are no target
    }
    constexpr GizmoPart axes[3] = {GizmoPart::AxisX, GizmoPart::AxisY, GizmoPart::AxisZ};
    for (int k = 0; k < 3; ++k) {
      // An axis seen end-on cannot be dragged along: it is not a target.
      if ((tips_px_[static_cast<std::size_t>(k)] - centre_px_).norm() < kMinimumPixels) continue;
      // From a little off the centre, so that a press on the centre is a free move.
      const Eigen::Vector2f start = centre_px_ + 0.15f * (tips_px_[static_cast<std::size_t>(k)] - centre_px_);
      const float distance = distance_to_segment(cursor, start, tips_px_[static_cast<std::size_t>(k)]);
      if (distance < best_distance) {
        best_distance = distance;
        best = axes[k];
      }
    }
    return best;
  }
  constexpr GizmoPart rings[3] = {GizmoPart::RingX, GizmoPart::RingY, GizmoPart::RingZ};
  for (int k = 0; k < 3; ++k) {
    const auto& ring = rings_px_[static_cast<std::size_t>(k)];
    for (std::size_t s = 0; s < ring.size(); ++s) {
      const float distance = distance_to_segment(cursor, ring[s], ring[(s + 1) % ring.size()]);
      if (distance < best_distance) {
        best_distance = distance;
        best = rings[k];
      }
    }
  }
  return best;
}

void HandleGizmo::draw(ImDrawList* list, GizmoPart highlighted) const {
  if (!laid_out_) return;
  const ImU32 colors[3] = {IM_COL32(230, 70, 70, 255), IM_COL32(80, 200, 80, 255), IM_COL32(80, 120, 240, 255)};
  const ImU32 bright = IM_COL32(255, 230, 90, 255);
  const auto point = [](const Eigen::Vector2f& p) { return ImVec2(p.x(), p.y()); };
  for (int k = 0; k < 3; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    if (mode_ == GizmoMode::Move) {
      const bool axis_lit = gizmo_axis(highlighted) == k && !is_plane(highlighted);
      list->AddLine(point(centre_px_), point(tips_px_[kk]), axis_lit ? bright : colors[k], axis_lit ? 3.5f : 2.0f);
      list->AddCircleFilled(point(tips_px_[kk]), 4.0f, axis_lit ? bright : colors[k]);
      const bool plane_lit = gizmo_axis(highlighted) == k && is_plane(highlighted);
      ImVec2 quad[4];
      for (std::size_t c = 0; c < 4; ++c) quad[c] = point(squares_px_[kk][c]);
      list->AddConvexPolyFilled(quad, 4, plane_lit ? IM_COL32(255, 230, 90, 160) : (colors[k] & 0x00FFFFFFu) | 0x60000000u);
    } else {
      const auto& ring = rings_px_[kk];
      std::vector<ImVec2> points;
      for (const auto& p : ring) points.push_back(point(p));
      const bool lit = gizmo_axis(highlighted) == k;
      list->AddPolyline(points.data(), static_cast<int>(points.size()), lit ? bright : colors[k], ImDrawFlags_Closed, lit ? 3.5f : 2.0f);
    }
  }
  list->AddCircle(point(centre_px_), 6.0f, IM_COL32(255, 255, 255, 255), 16, 2.0f);
}

}  // namespace hdeform::cli

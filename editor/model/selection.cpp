#include "selection.h"

#include <Eigen/Geometry>
#include <algorithm>

namespace hdeform::cli {

VertexAdjacency::VertexAdjacency(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count) {
  // Each triangle's edges both ways, bucketed by their first vertex (a counting sort: sorting
  // the 20 million pairs of a 3.3M-triangle scan took 1.3 s of its opening); then each vertex's
  // few neighbours sorted and made unique in place, and the lists closed up.
  const auto n = static_cast<std::size_t>(vertex_count);
  std::vector<int> next(n + 1, 0);
  auto each_edge = [&](auto&& visit) {
    for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const int a = triangles(t, k), b = triangles(t, (k + 1) % 3);
        if (a == b) continue;
        visit(a, b);
        visit(b, a);
      }
    }
  };
  each_edge([&](int a, int) { ++next[static_cast<std::size_t>(a) + 1]; });
  for (std::size_t v = 0; v < n; ++v) next[v + 1] += next[v];
  std::vector<int> bucket_start(next.begin(), next.end());
  std::vector<int> listed(static_cast<std::size_t>(next[n]));
  each_edge([&](int a, int b) { listed[static_cast<std::size_t>(next[static_cast<std::size_t>(a)]++)] = b; });
  start_.assign(n + 1, 0);
  neighbours_.clear();
  neighbours_.reserve(listed.size() / 2);
  for (std::size_t v = 0; v < n; ++v) {
    const auto first = listed.begin() + bucket_start[v], last = listed.begin() + bucket_start[v + 1];
    std::sort(first, last);
    neighbours_.insert(neighbours_.end(), first, std::unique(first, last));
    start_[v + 1] = static_cast<int>(neighbours_.size());
  }
}

namespace {

// Centres of a stroke, a few at a time with their box grown by the radius: the stamps of a stroke
// lie along a path, so most points are rejected by a few boxes, not tested against every stamp.
template <int Dimension>
class CentreGroups {
 public:
  using Point = Eigen::Matrix<float, Dimension, 1>;
  CentreGroups(std::span<const Point> centres, float radius) : centres_(centres), radius_squared_(radius * radius) {
    for (std::size_t first = 0; first < centres.size(); first += kPerGroup) {
      Eigen::AlignedBox<float, Dimension> box;
      for (std::size_t k = first; k < std::min(first + kPerGroup, centres.size()); ++k) box.extend(centres[k]);
      box.min().array() -= radius;
      box.max().array() += radius;
      boxes_.push_back(box);
      all_.extend(box);
    }
  }
  bool contain(const Point& point) const {
    if (boxes_.empty() || !all_.contains(point)) return false;
    for (std::size_t g = 0; g < boxes_.size(); ++g) {
      if (!boxes_[g].contains(point)) continue;
      for (std::size_t k = g * kPerGroup; k < std::min((g + 1) * kPerGroup, centres_.size()); ++k) {
        if ((point - centres_[k]).squaredNorm() <= radius_squared_) return true;
      }
    }
    return false;
  }

 private:
  static constexpr std::size_t kPerGroup = 8;
  std::span<const Point> centres_;
  float radius_squared_;
  std::vector<Eigen::AlignedBox<float, Dimension>> boxes_;
  Eigen::AlignedBox<float, Dimension> all_;
};

}  // namespace

std::vector<int> vertices_in_balls(std::span<const float> position_normal, std::span<const Eigen::Vector3f> centres, float radius) {
  const CentreGroups<3> groups(centres, radius);
  std::vector<int> inside;
  const std::size_t n = position_normal.size() / 6;
  for (std::size_t v = 0; v < n; ++v) {
    if (groups.contain(Eigen::Vector3f(position_normal[6 * v], position_normal[6 * v + 1], position_normal[6 * v + 2]))) inside.push_back(static_cast<int>(v));
  }
  return inside;
}

std::vector<int> vertices_in_ball(std::span<const float> position_normal, const Eigen::Vector3f& center, float radius) {
  return vertices_in_balls(position_normal, std::span(&center, 1), radius);
}

std::vector<Eigen::Vector2f> stamps_along(const Eigen::Vector2f& from, std::span<const Eigen::Vector2f> path, float spacing) {
  std::vector<Eigen::Vector2f> stamps;
  Eigen::Vector2f start = from;
  float since_stamp = 0.0f;  // along the path
  for (const Eigen::Vector2f& point : path) {
    const Eigen::Vector2f leg = point - start;
    const float length = leg.norm();
    if (length == 0.0f) continue;
    float at = spacing - since_stamp;
    for (; at <= length; at += spacing) stamps.push_back(start + leg * (at / length));
    since_stamp = length - (at - spacing);
    start = point;
  }
  if (since_stamp > 0.0f) stamps.push_back(start);
  return stamps;
}

namespace {

// A vertex's pixel (y down), or nothing behind the camera.
std::optional<Eigen::Vector2f> project_to_pixel(const float* position, const Eigen::Matrix4f& view_projection, float width, float height) {
  const Eigen::Vector4f clip = view_projection * Eigen::Vector4f(position[0], position[1], position[2], 1.0f);
  if (clip.w() <= 0.0f) return std::nullopt;
  return Eigen::Vector2f((clip.x() / clip.w() * 0.5f + 0.5f) * width, (clip.y() / clip.w() * 0.5f + 0.5f) * height);
}

}  // namespace

std::vector<int> vertices_in_screen_discs(std::span<const float> position_normal, std::span<const Eigen::Vector2f> centres, float radius,
                                          const Eigen::Matrix4f& view_projection, float width, float height) {
  const CentreGroups<2> groups(centres, radius);
  std::vector<int> inside;
  const std::size_t n = position_normal.size() / 6;
  for (std::size_t v = 0; v < n; ++v) {
    const auto pixel = project_to_pixel(position_normal.data() + 6 * v, view_projection, width, height);
    if (pixel && groups.contain(*pixel)) inside.push_back(static_cast<int>(v));
  }
  return inside;
}

std::vector<int> vertices_in_screen_disc(std::span<const float> position_normal, const Eigen::Vector2f& center, float radius,
                                         const Eigen::Matrix4f& view_projection, float width, float height) {
  return vertices_in_screen_discs(position_normal, std::span(&center, 1), radius, view_projection, width, height);
}

std::vector<int> vertices_in_lasso(std::span<const float> position_normal, std::span<const Eigen::Vector2f> polygon,
                                   const Eigen::Matrix4f& view_projection, float width, float height,
                                   const std::optional<Eigen::Vector3f>& towards_viewer) {
  std::vector<int> inside;
  if (polygon.size() < 3) return inside;
  const std::size_t n = position_normal.size() / 6;
  for (std::size_t v = 0; v < n; ++v) {
    const float* data = position_normal.data() + 6 * v;
    if (towards_viewer && Eigen::Vector3f(data[3], data[4], data[5]).dot(*towards_viewer) <= 0.0f) continue;
    const auto projected = project_to_pixel(data, view_projection, width, height);
    if (!projected) continue;
    const Eigen::Vector2f& pixel = *projected;
    // Even-odd rule.
    bool in = false;
    for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
      const auto& a = polygon[i];
      const auto& b = polygon[j];
      if ((a.y() > pixel.y()) != (b.y() > pixel.y()) && pixel.x() < (b.x() - a.x()) * (pixel.y() - a.y()) / (b.y() - a.y()) + a.x()) in = !in;
    }
    if (in) inside.push_back(static_cast<int>(v));
  }
  return inside;
}

std::vector<bool> grown(const std::vector<bool>& members, const VertexAdjacency& adjacency) {
  std::vector<bool> result = members;
  for (std::size_t v = 0; v < members.size(); ++v) {
    if (!members[v]) continue;
    for (const int u : adjacency.neighbours(static_cast<int>(v))) result[static_cast<std::size_t>(u)] = true;
  }
  return result;
}

std::vector<bool> shrunk(const std::vector<bool>& members, const VertexAdjacency& adjacency) {
  std::vector<bool> result = members;
  for (std::size_t v = 0; v < members.size(); ++v) {
    if (!members[v]) continue;
    for (const int u : adjacency.neighbours(static_cast<int>(v))) {
      if (!members[static_cast<std::size_t>(u)]) {
        result[v] = false;
        break;
      }
    }
  }
  return result;
}

std::vector<int> connected_vertices(int seed, const VertexAdjacency& adjacency) {
  std::vector<bool> seen(adjacency.vertex_count(), false);
  std::vector<int> found{seed}, stack{seed};
  seen[static_cast<std::size_t>(seed)] = true;
  while (!stack.empty()) {
    const int v = stack.back();
    stack.pop_back();
    for (const int u : adjacency.neighbours(v)) {
      if (seen[static_cast<std::size_t>(u)]) continue;
      seen[static_cast<std::size_t>(u)] = true;
      found.push_back(u);
      stack.push_back(u);
    }
  }
  std::sort(found.begin(), found.end());
  return found;
}

}  // namespace hdeform::cli

#include "mesh_picker.h"

#include <algorithm>
#include <limits>

namespace hdeform::cli {
namespace {

constexpr int kLeafTriangles = 4;

// Möller–Trumbore, both sides; returns the distance along the ray or nullopt. A ray through a
// shared vertex or edge must not slip between the triangles there: barycentric tests allow a
// hair of slack.
constexpr float kEdgeSlack = 1e-6f;
std::optional<float> intersect(const Eigen::ParametrizedLine<float, 3>& ray, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                               const Eigen::Vector3f& c, Eigen::Vector2f& barycentric) {
  const Eigen::Vector3f e1 = b - a, e2 = c - a;
  const Eigen::Vector3f p = ray.direction().cross(e2);
  const float determinant = e1.dot(p);
  if (std::abs(determinant) < 1e-20f) return std::nullopt;
  const float inverse = 1.0f / determinant;
  const Eigen::Vector3f s = ray.origin() - a;
  const float u = s.dot(p) * inverse;
  if (u < -kEdgeSlack || u > 1.0f + kEdgeSlack) return std::nullopt;
  const Eigen::Vector3f q = s.cross(e1);
  const float v = ray.direction().dot(q) * inverse;
  if (v < -kEdgeSlack || u + v > 1.0f + kEdgeSlack) return std::nullopt;
  const float t = e2.dot(q) * inverse;
  if (t <= 0.0f) return std::nullopt;
  barycentric = {u, v};
  return t;
}

bool hits_box(const Eigen::ParametrizedLine<float, 3>& ray, const Eigen::Vector3f& inverse_direction, const Eigen::AlignedBox3f& box,
              float limit) {
  float near_t = 0.0f, far_t = limit;
  for (int axis = 0; axis < 3; ++axis) {
    if (ray.direction()(axis) == 0.0f) {  // parallel to this slab: 0 · ∞ would be NaN
      if (ray.origin()(axis) < box.min()(axis) || ray.origin()(axis) > box.max()(axis)) return false;
      continue;
    }
    float t0 = (box.min()(axis) - ray.origin()(axis)) * inverse_direction(axis);
    float t1 = (box.max()(axis) - ray.origin()(axis)) * inverse_direction(axis);
    if (t0 > t1) std::swap(t0, t1);
    near_t = std::max(near_t, t0);
    far_t = std::min(far_t, t1);
    if (near_t > far_t) return false;
  }
  return true;
}

}  // namespace

MeshPicker::MeshPicker(const Eigen::MatrixXi& triangles, std::span<const float> position_normal)
    : triangles_(triangles), positions_(position_normal.begin(), position_normal.end()) {
  order_.resize(static_cast<std::size_t>(triangles.rows()));
  for (std::size_t t = 0; t < order_.size(); ++t) order_[t] = static_cast<int>(t);
  nodes_.reserve(2 * order_.size() / kLeafTriangles + 2);
  if (!order_.empty()) build(0, static_cast<int>(order_.size()));
}

// Splits order_[begin, end) at the median centroid along the longest axis; appends the node and
// then its subtrees (so children come after their parent) and returns the node's index.
int MeshPicker::build(int begin, int end) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3f box, centroids;
  for (int k = begin; k < end; ++k) {
    const int t = order_[static_cast<std::size_t>(k)];
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3f p = vertex(triangles_(t, c));
      box.extend(p);
      centroid += p / 3.0f;
    }
    centroids.extend(centroid);
  }
  nodes_[static_cast<std::size_t>(index)].box = box;
  if (end - begin <= kLeafTriangles) {
    nodes_[static_cast<std::size_t>(index)].first = begin;
    nodes_[static_cast<std::size_t>(index)].count = end - begin;
    return index;
  }
  int axis = 0;
  centroids.sizes().maxCoeff(&axis);
  const int middle = begin + (end - begin) / 2;
  auto centroid_of = [&](int t) {
    return vertex(triangles_(t, 0))(axis) + vertex(triangles_(t, 1))(axis) + vertex(triangles_(t, 2))(axis);
  };
  std::nth_element(order_.begin() + begin, order_.begin() + middle, order_.begin() + end,
                   [&](int a, int b) { return centroid_of(a) != centroid_of(b) ? centroid_of(a) < centroid_of(b) : a < b; });
  const int left = build(begin, middle);
  const int right = build(middle, end);
  nodes_[static_cast<std::size_t>(index)].first = left;
  nodes_[static_cast<std::size_t>(index)].count = -right;  // inner node: minus the right child
  return index;
}

void MeshPicker::refit(std::span<const float> position_normal) {
  positions_.assign(position_normal.begin(), position_normal.end());
  // Children are stored after their parent: refit from the back.
  for (std::size_t k = nodes_.size(); k-- > 0;) {
    Node& node = nodes_[k];
    Eigen::AlignedBox3f box;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        const int t = order_[static_cast<std::size_t>(i)];
        for (int c = 0; c < 3; ++c) box.extend(vertex(triangles_(t, c)));
      }
    } else if (node.count < 0) {
      box = nodes_[static_cast<std::size_t>(node.first)].box;
      box.extend(nodes_[static_cast<std::size_t>(-node.count)].box);
    }
    node.box = box;
  }
}

std::optional<MeshPicker::Hit> MeshPicker::pick(const Eigen::ParametrizedLine<float, 3>& ray) const {
  if (order_.empty()) return std::nullopt;
  const Eigen::Vector3f inverse_direction = ray.direction().cwiseInverse();
  float best = std::numeric_limits<float>::infinity();
  Hit hit;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[static_cast<std::size_t>(stack[--top])];
    if (!hits_box(ray, inverse_direction, node.box, best)) continue;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        const int t = order_[static_cast<std::size_t>(i)];
        Eigen::Vector2f barycentric = Eigen::Vector2f::Zero();
        const auto distance = intersect(ray, vertex(triangles_(t, 0)), vertex(triangles_(t, 1)), vertex(triangles_(t, 2)), barycentric);
        if (!distance || *distance >= best) continue;
        best = *distance;
        hit.triangle = t;
        hit.distance = *distance;
        hit.point = ray.pointAt(*distance);
        const float weights[3] = {1.0f - barycentric.x() - barycentric.y(), barycentric.x(), barycentric.y()};
        hit.vertex = triangles_(t, static_cast<int>(std::max_element(weights, weights + 3) - weights));
      }
    } else if (node.count < 0 && top + 2 <= 128) {
      stack[top++] = node.first;
      stack[top++] = -node.count;
    }
  }
  if (hit.triangle < 0) return std::nullopt;
  return hit;
}

}  // namespace hdeform::cli

#include "mesh_picker.h"

#include <algorithm>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

namespace hdeform::cli {
namespace {

constexpr int kLeafTriangles = 4;
// Subtrees of at least this many triangles build and refit their halves side by side.
constexpr int kParallelTriangles = 1 << 15;

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
    : triangles_(triangles) {
  keep_positions(position_normal);
  build_tree();
}

MeshPicker::MeshPicker(const Eigen::MatrixXi& triangles, const Eigen::MatrixXd& positions)
    : triangles_(triangles), positions_(static_cast<std::size_t>(3 * positions.rows())) {
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    for (int c = 0; c < 3; ++c) positions_[static_cast<std::size_t>(3 * v + c)] = static_cast<float>(positions(v, c));
  }
  build_tree();
}

void MeshPicker::build_tree() {
  const int count = static_cast<int>(triangles_.rows());
  if (count == 0) return;
  // The splits sort by centroid: computed once, kept beside each triangle's index so that a
  // split reads its range in order (at 3.3 million triangles, recomputing them from the corners
  // at every level took 3 s; this build takes a fifth of that on one thread).
  std::vector<Centred> centred(static_cast<std::size_t>(count));
  tbb::parallel_for(tbb::blocked_range<int>(0, count), [&](const tbb::blocked_range<int>& range) {
    for (int t = range.begin(); t < range.end(); ++t) {
      centred[static_cast<std::size_t>(t)] = {vertex(triangles_(t, 0)) + vertex(triangles_(t, 1)) + vertex(triangles_(t, 2)), t};
    }
  });
  SubtreeSizes sizes;
  nodes_.resize(static_cast<std::size_t>(sizes.nodes(count)));
  build(sizes, centred, 0, count, 0);
  order_.resize(centred.size());
  for (std::size_t k = 0; k < centred.size(); ++k) order_[k] = centred[k].triangle;
  fit_boxes();
}

// The nodes of a subtree over `count` triangles: every split halves, so the count decides, and
// a tree holds only two counts per level. Filled before the build, which only reads it.
int MeshPicker::SubtreeSizes::nodes(int count) {
  if (count <= kLeafTriangles) return 1;
  if (const auto known = nodes_of_.find(count); known != nodes_of_.end()) return known->second;
  const int total = 1 + nodes(count / 2) + nodes(count - count / 2);
  nodes_of_.emplace(count, total);
  return total;
}

int MeshPicker::SubtreeSizes::known_nodes(int count) const { return count <= kLeafTriangles ? 1 : nodes_of_.at(count); }

// Splits centred[begin, end) at the median centroid along the centroids' longest axis, at node
// `index`; the left subtree follows it and the right one follows the left, so every node's place
// is fixed before the halves are built, and they are built in parallel with the same result.
void MeshPicker::build(const SubtreeSizes& sizes, std::vector<Centred>& centred, int begin, int end, int index) {
  Node& node = nodes_[static_cast<std::size_t>(index)];
  if (end - begin <= kLeafTriangles) {
    node.first = begin;
    node.count = end - begin;
    return;
  }
  Eigen::AlignedBox3f centroids;
  for (int k = begin; k < end; ++k) centroids.extend(centred[static_cast<std::size_t>(k)].centroid);
  int axis = 0;
  centroids.sizes().maxCoeff(&axis);
  const int middle = begin + (end - begin) / 2;
  std::nth_element(centred.begin() + begin, centred.begin() + middle, centred.begin() + end, [axis](const Centred& a, const Centred& b) {
    return a.centroid(axis) != b.centroid(axis) ? a.centroid(axis) < b.centroid(axis) : a.triangle < b.triangle;
  });
  const int left = index + 1;
  const int right = left + sizes.known_nodes(middle - begin);
  node.first = left;
  node.count = -right;  // inner node: minus the right child
  if (end - begin >= kParallelTriangles) {
    tbb::parallel_invoke([&] { build(sizes, centred, begin, middle, left); }, [&] { build(sizes, centred, middle, end, right); });
  } else {
    build(sizes, centred, begin, middle, left);
    build(sizes, centred, middle, end, right);
  }
}

void MeshPicker::refit(std::span<const float> position_normal) {
  keep_positions(position_normal);
  fit_boxes();
}

// The positions alone: half the bytes to copy and to read back.
void MeshPicker::keep_positions(std::span<const float> position_normal) {
  const std::size_t vertex_count = position_normal.size() / 6;
  positions_.resize(3 * vertex_count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertex_count, std::size_t{1} << 14), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      for (std::size_t c = 0; c < 3; ++c) positions_[3 * v + c] = position_normal[6 * v + c];
    }
  });
}

void MeshPicker::fit_boxes() {
  if (!nodes_.empty()) fit_subtree(0, 0, static_cast<int>(order_.size()));
}

// A refit follows every change on screen while a paint tool hovers, so it runs on every core: the
// halves of large subtrees side by side (60 ms on one thread at 3.3 million triangles). Each box
// is the same whatever the schedule.
const Eigen::AlignedBox3f& MeshPicker::fit_subtree(int index, int begin, int end) {
  Node& node = nodes_[static_cast<std::size_t>(index)];
  if (node.count >= 0) {
    Eigen::AlignedBox3f box;
    for (int i = node.first; i < node.first + node.count; ++i) {
      const int t = order_[static_cast<std::size_t>(i)];
      for (int c = 0; c < 3; ++c) box.extend(vertex(triangles_(t, c)));
    }
    node.box = box;
    return node.box;
  }
  const int middle = begin + (end - begin) / 2;
  if (end - begin >= kParallelTriangles) {
    tbb::parallel_invoke([&] { fit_subtree(node.first, begin, middle); }, [&] { fit_subtree(-node.count, middle, end); });
  } else {
    fit_subtree(node.first, begin, middle);
    fit_subtree(-node.count, middle, end);
  }
  Eigen::AlignedBox3f box = nodes_[static_cast<std::size_t>(node.first)].box;
  box.extend(nodes_[static_cast<std::size_t>(-node.count)].box);
  node.box = box;
  return node.box;
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

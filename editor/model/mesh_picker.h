#pragma once
// Picking the triangle under the cursor: a bounding volume hierarchy over the triangles, built
// once per mesh and refitted (not rebuilt) when the positions change during an edit.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

namespace hdeform::cli {

class MeshPicker {
 public:
  struct Hit {
    int triangle = -1;
    int vertex = -1;  // the corner of the triangle nearest the hit
    Eigen::Vector3f point = Eigen::Vector3f::Zero();
    float distance = 0.0f;
  };

  // `position_normal`: 6 floats per vertex (position, normal), as the renderer receives them.
  MeshPicker(const Eigen::MatrixXi& triangles, std::span<const float> position_normal);
  // The same from positions (one row per vertex).
  MeshPicker(const Eigen::MatrixXi& triangles, const Eigen::MatrixXd& positions);

  // Refits the boxes to new positions (same layout); O(triangles).
  void refit(std::span<const float> position_normal);
  // The nearest triangle the ray hits (either side), if any.
  std::optional<Hit> pick(const Eigen::ParametrizedLine<float, 3>& ray) const;

 private:
  struct Node {
    Eigen::AlignedBox3f box;
    int first = 0;  // leaves: first index into order_; inner nodes: the left child
    int count = 0;  // leaves: number of triangles (> 0); inner nodes: minus the right child
  };
  struct Centred {
    Eigen::Vector3f centroid;  // three times the centroid: only the order matters
    int triangle = 0;
  };
  Eigen::Vector3f vertex(int v) const { return {positions_[3 * v], positions_[3 * v + 1], positions_[3 * v + 2]}; }
  class SubtreeSizes {
   public:
    int nodes(int triangles);              // computes and keeps
    int known_nodes(int triangles) const;  // one computed before
   private:
    std::unordered_map<int, int> nodes_of_;
  };
  void build(const SubtreeSizes& sizes, std::vector<Centred>& centred, int begin, int end, int index);
  void keep_positions(std::span<const float> position_normal);
  void build_tree();
  void fit_boxes();
  const Eigen::AlignedBox3f& fit_subtree(int index, int begin, int end);  // the triangles order_[begin, end)

  Eigen::MatrixXi triangles_;
  std::vector<float> positions_;  // x, y, z per vertex
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

}  // namespace hdeform::cli

#pragma once
// Vertex selection for painting classes: a brush ball, a screen-space lasso, growing and
// shrinking by one ring, and the connected part under a vertex. Positions come as the renderer
// receives them: 6 floats per vertex (position, normal).
#include <Eigen/Core>
#include <optional>
#include <span>
#include <vector>

namespace hdeform::cli {

// One-ring neighbours of every vertex.
class VertexAdjacency {
 public:
  VertexAdjacency(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count);
  std::span<const int> neighbours(int vertex) const {
    return {neighbours_.data() + start_[static_cast<std::size_t>(vertex)],
            static_cast<std::size_t>(start_[static_cast<std::size_t>(vertex) + 1] - start_[static_cast<std::size_t>(vertex)])};
  }
  std::size_t vertex_count() const { return start_.size() - 1; }

 private:
  std::vector<int> start_;
  std::vector<int> neighbours_;
};

// Vertices within `radius` of `center`; of any of `centres` (a stroke's stamps), in one pass.
std::vector<int> vertices_in_ball(std::span<const float> position_normal, const Eigen::Vector3f& center, float radius);
std::vector<int> vertices_in_balls(std::span<const float> position_normal, std::span<const Eigen::Vector3f> centres, float radius);

// A brush stroke's stamps after the one at `from`, as the pointer went on through `path`: a stamp
// every `spacing` pixels along the way (so a stroke is continuous however far the pointer moved
// between two frames) and one where the path ends.
std::vector<Eigen::Vector2f> stamps_along(const Eigen::Vector2f& from, std::span<const Eigen::Vector2f> path, float spacing);

// Vertices whose projection (view_projection, a width×height view, y down) lies inside the
// polygon (pixels) and whose normal faces `towards_viewer`: what the user sees inside the lasso.
// Without `towards_viewer` (paint-through), every vertex inside, front and back.
std::vector<int> vertices_in_lasso(std::span<const float> position_normal, std::span<const Eigen::Vector2f> polygon,
                                   const Eigen::Matrix4f& view_projection, float width, float height,
                                   const std::optional<Eigen::Vector3f>& towards_viewer);

// Paint-through brush: every vertex whose projection lies within `radius` pixels of `center`,
// whatever its depth (a ring painted from one side is the whole ring).
std::vector<int> vertices_in_screen_disc(std::span<const float> position_normal, const Eigen::Vector2f& center, float radius,
                                         const Eigen::Matrix4f& view_projection, float width, float height);
std::vector<int> vertices_in_screen_discs(std::span<const float> position_normal, std::span<const Eigen::Vector2f> centres, float radius,
                                          const Eigen::Matrix4f& view_projection, float width, float height);

// The members plus every neighbour of a member.
std::vector<bool> grown(const std::vector<bool>& members, const VertexAdjacency& adjacency);
// The members without those that have a non-member neighbour.
std::vector<bool> shrunk(const std::vector<bool>& members, const VertexAdjacency& adjacency);
// The vertices connected to `seed` through edges.
std::vector<int> connected_vertices(int seed, const VertexAdjacency& adjacency);

}  // namespace hdeform::cli

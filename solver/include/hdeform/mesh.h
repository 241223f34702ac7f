#pragma once
#include <Eigen/Core>

namespace hdeform {

// A triangle mesh as plain data: positions n×3 and triangles m×3 (0-based vertex indices,
// counter-clockwise seen from outside).
struct Mesh {
  Eigen::MatrixXd positions;
  Eigen::MatrixXi triangles;

  Eigen::Index vertex_count() const { return positions.rows(); }
  Eigen::Index triangle_count() const { return triangles.rows(); }
};

// Length of the diagonal of the axis-aligned bounding box (0 for no points).
double bounding_box_diagonal(const Eigen::MatrixXd& positions);

}  // namespace hdeform

#pragma once
#include <Eigen/Core>
#include <string_view>

namespace hdeform {

/// A triangle mesh as plain data: positions n×3 and triangles m×3 (0-based vertex indices,
/// counter-clockwise seen from outside).
struct Mesh {
  Eigen::MatrixXd positions;
  Eigen::MatrixXi triangles;

  /// n, the number of vertices.
  Eigen::Index vertex_count() const { return positions.rows(); }
  /// m, the number of triangles.
  Eigen::Index triangle_count() const { return triangles.rows(); }
};

/// The check at the door of the library, O(n + m): positions n×3 and finite, triangles m×3 with
/// every index in [0, n). Throws InputError "<name>: <element>: <problem>" naming the first bad
/// vertex or triangle. Every public entry point that takes a mesh from outside runs it; the
/// algorithms inside trust its result.
void validate_mesh(const Mesh& mesh, std::string_view name = "mesh");
/// The same check on the two arrays of a mesh-to-be.
void validate_mesh(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles, std::string_view name = "mesh");
/// Its triangle half, for those who hold triangles and a vertex count (the renderer).
void validate_triangles(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count, std::string_view name = "mesh");

/// Length of the diagonal of the axis-aligned bounding box (0 for no points).
double bounding_box_diagonal(const Eigen::MatrixXd& positions);

/// Area-weighted unit vertex normals, n × 3 (zero for a vertex in no triangle of nonzero area).
Eigen::MatrixXd vertex_normals(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles);

/// Polygons (`sizes[p]` corners each, their vertex indices one polygon after another in `corners`)
/// as triangles, by the rule every mesh reader follows: a quad is split along its shorter diagonal
/// (a tie takes the one from its second corner), a larger polygon into a fan from its first corner.
/// Throws InputError naming the polygon that has fewer than three corners or an index outside
/// [0, positions.rows()), or when the sizes do not add up to the corners.
Eigen::MatrixXi triangulate_polygons(const Eigen::MatrixXd& positions, const Eigen::VectorXi& sizes, const Eigen::VectorXi& corners);

}  // namespace hdeform

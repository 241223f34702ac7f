#include "hdeform/mesh.h"

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "hdeform/errors.h"

namespace hdeform {
namespace {

std::string shown(double value) {
  if (std::isnan(value)) return "nan";
  return value > 0 ? "inf" : "-inf";
}

}  // namespace

void validate_mesh(const Mesh& mesh, std::string_view name) { validate_mesh(mesh.positions, mesh.triangles, name); }

void validate_mesh(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles, std::string_view name) {
  const std::string prefix = std::string(name) + ": ";
  if (positions.cols() != 3) {
    throw InputError(prefix + "positions must have 3 columns (x, y, z), not " + std::to_string(positions.cols()));
  }
  const Eigen::Index n = positions.rows();
  for (Eigen::Index v = 0; v < n; ++v) {
    for (int c = 0; c < 3; ++c) {
      const double value = positions(v, c);
      if (!std::isfinite(value)) {
        throw InputError(prefix + "vertex " + std::to_string(v) + " has a non-finite coordinate " + "xyz"[c] + " = " + shown(value));
      }
    }
  }
  validate_triangles(triangles, n, name);
}

void validate_triangles(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count, std::string_view name) {
  const std::string prefix = std::string(name) + ": ";
  if (triangles.cols() != 3) {
    throw InputError(prefix + "triangles must have 3 columns (vertex indices), not " + std::to_string(triangles.cols()));
  }
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const int index = triangles(t, c);
      if (index < 0 || index >= vertex_count) {
        throw InputError(prefix + "triangle " + std::to_string(t) + " corner " + std::to_string(c) + " has vertex index " +
                         std::to_string(index) + ", out of range (the mesh has " + std::to_string(vertex_count) + " vertices)");
      }
    }
  }
}

double bounding_box_diagonal(const Eigen::MatrixXd& positions) {
  if (positions.rows() == 0) return 0.0;
  return (positions.colwise().maxCoeff() - positions.colwise().minCoeff()).norm();
}

Eigen::MatrixXd vertex_normals(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles) {
  Eigen::MatrixXd normals = Eigen::MatrixXd::Zero(positions.rows(), 3);
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    const Eigen::RowVector3d a = positions.row(triangles(t, 0)), b = positions.row(triangles(t, 1)), c = positions.row(triangles(t, 2));
    // Twice the triangle's area along its normal: the area weighting comes for free.
    const Eigen::RowVector3d area_normal = (b - a).cross(c - a);
    for (int corner = 0; corner < 3; ++corner) normals.row(triangles(t, corner)) += area_normal;
  }
  for (Eigen::Index v = 0; v < normals.rows(); ++v) {
    const double length = normals.row(v).norm();
    if (length > 0.0) normals.row(v) /= length;
  }
  return normals;
}

}  // namespace hdeform

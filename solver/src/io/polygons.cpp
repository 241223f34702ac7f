#include "polygons.h"

#include <string>

#include "hdeform/errors.h"

namespace hdeform::detail {
namespace {

// Summed in a fixed order, so that a tie between the two diagonals is decided the same everywhere.
double squared_distance(const Eigen::MatrixXd& positions, int a, int b) {
  double sum = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double d = positions(b, c) - positions(a, c);
    sum += d * d;
  }
  return sum;
}

}  // namespace

void triangulate(const Polygons& polygons, const Eigen::MatrixXd& positions, Eigen::MatrixXi& triangles) {
  std::size_t count = 0;
  for (std::size_t p = 0; p < polygons.count(); ++p) count += polygons.start[p + 1] - polygons.start[p] - 2;
  triangles.resize(static_cast<Eigen::Index>(count), 3);
  Eigen::Index t = 0;
  const auto add = [&](int a, int b, int c) { triangles.row(t++) << a, b, c; };
  for (std::size_t p = 0; p < polygons.count(); ++p) {
    const int* corner = polygons.corners.data() + polygons.start[p];
    const std::size_t size = polygons.start[p + 1] - polygons.start[p];
    if (size == 4) {
      if (squared_distance(positions, corner[0], corner[2]) < squared_distance(positions, corner[1], corner[3])) {
        add(corner[0], corner[1], corner[2]);
        add(corner[0], corner[2], corner[3]);
      } else {
        add(corner[0], corner[1], corner[3]);
        add(corner[1], corner[2], corner[3]);
      }
      continue;
    }
    for (std::size_t k = 1; k + 1 < size; ++k) add(corner[0], corner[k], corner[k + 1]);
  }
}

}  // namespace hdeform::detail

namespace hdeform {

Eigen::MatrixXi triangulate_polygons(const Eigen::MatrixXd& positions, const Eigen::VectorXi& sizes, const Eigen::VectorXi& corners) {
  detail::Polygons polygons;
  Eigen::Index at = 0;
  for (Eigen::Index p = 0; p < sizes.size(); ++p) {
    const int size = sizes(p);
    if (size < 3) throw InputError("polygon " + std::to_string(p) + ": " + std::to_string(size) + " corners (at least 3 make a face)");
    if (at + size > corners.size()) throw InputError("polygon " + std::to_string(p) + ": the polygon sizes add up to more corners than given");
    for (int k = 0; k < size; ++k) {
      const int vertex = corners(at + k);
      if (vertex < 0 || vertex >= positions.rows()) {
        throw InputError("polygon " + std::to_string(p) + ": vertex " + std::to_string(vertex) + " out of range (" +
                         std::to_string(positions.rows()) + " vertices)");
      }
    }
    polygons.add(corners.data() + at, static_cast<std::size_t>(size));
    at += size;
  }
  if (at != corners.size()) throw InputError("the polygon sizes add up to " + std::to_string(at) + " corners, not " + std::to_string(corners.size()));
  Eigen::MatrixXi triangles;
  detail::triangulate(polygons, positions, triangles);
  return triangles;
}

}  // namespace hdeform

namespace hdeform::detail {

Mesh mesh_of(const std::vector<std::array<double, 3>>& points, const Polygons& polygons, std::string_view name) {
  Mesh mesh;
  mesh.positions.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t v = 0; v < points.size(); ++v) {
    for (int c = 0; c < 3; ++c) mesh.positions(static_cast<Eigen::Index>(v), c) = points[v][static_cast<std::size_t>(c)];
  }
  triangulate(polygons, mesh.positions, mesh.triangles);
  validate_mesh(mesh, name);
  return mesh;
}

}  // namespace hdeform::detail

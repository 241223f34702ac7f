#include "polygons.h"

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

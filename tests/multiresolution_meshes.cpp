#include "multiresolution_meshes.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "hdeform/mesh_check.h"
#include "hdeform/shapes.h"
#include "hdeform/subdivision.h"

namespace hdeform::test {
namespace {

constexpr double kPi = std::numbers::pi;

}  // namespace

Mesh torus(int around, int across, bool open) {
  Mesh mesh;
  const int rings = open ? around + 1 : around;
  mesh.positions.resize(rings * across, 3);
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < across; ++j) {
      const double u = 2 * kPi * i / around * (open ? 0.75 : 1.0), v = 2 * kPi * j / across;
      const double r = 0.35 * (1 + 0.05 * std::sin(5 * u) * std::cos(3 * v));
      mesh.positions.row(i * across + j) << (1 + r * std::cos(v)) * std::cos(u), (1 + r * std::cos(v)) * std::sin(u), r * std::sin(v);
    }
  }
  const int cells = open ? around : around;
  mesh.triangles.resize(2 * cells * across, 3);
  int t = 0;
  for (int i = 0; i < cells; ++i) {
    for (int j = 0; j < across; ++j) {
      const int a = i * across + j, b = ((i + 1) % rings) * across + j, c = ((i + 1) % rings) * across + (j + 1) % across,
                d = i * across + (j + 1) % across;
      mesh.triangles.row(t++) << a, b, c;
      mesh.triangles.row(t++) << a, c, d;
    }
  }
  return mesh;
}

Relief bar_with_relief() {
  const Shape bar = make_shape(ShapeKind::Bar, 16);
  Relief relief;
  Subdivision once = subdivide(bar.mesh);
  Subdivision twice = subdivide(once.mesh);
  relief.constraints = subdivided_constraints(subdivided_constraints(bar.demo_constraints, once), twice);
  relief.mesh = twice.mesh;
  relief.transform = bar.demo_transform;
  relief.diagonal = bounding_box_diagonal(relief.mesh.positions);
  add_relief(relief.mesh, 0.004);
  return relief;
}

Mesh sphere_denser_in_the_north(double southern_edge) {
  auto edge_at = [&](double theta) { return theta < kPi / 2 ? southern_edge / 2 : southern_edge; };
  std::vector<double> latitudes{0.0};
  while (latitudes.back() < kPi) latitudes.push_back(latitudes.back() + edge_at(latitudes.back()) * std::sqrt(3.0) / 2);
  latitudes.back() = kPi;
  std::vector<Eigen::RowVector3d> points;
  std::vector<std::vector<int>> rings;
  for (std::size_t r = 0; r < latitudes.size(); ++r) {
    const double theta = latitudes[r], shift = 0.5 * static_cast<double>(r % 2);
    const bool pole = r == 0 || r + 1 == latitudes.size();
    const int count = pole ? 1 : std::max(3, static_cast<int>(std::lround(2 * kPi * std::sin(theta) / edge_at(theta))));
    std::vector<int>& ring = rings.emplace_back();
    for (int k = 0; k < count; ++k) {
      const double phi = 2 * kPi * (k + shift) / count, radius = 1 + 0.03 * std::sin(5 * theta) * std::cos(4 * phi);
      ring.push_back(static_cast<int>(points.size()));
      points.emplace_back(radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi), radius * std::cos(theta));
    }
  }
  std::vector<Eigen::RowVector3i> triangles;
  for (std::size_t r = 0; r + 1 < rings.size(); ++r) {
    const std::vector<int>&upper = rings[r], &lower = rings[r + 1];
    const auto nu = static_cast<int>(upper.size()), nl = static_cast<int>(lower.size());
    const double shift_upper = 0.5 * static_cast<double>(r % 2), shift_lower = 0.5 * static_cast<double>((r + 1) % 2);
    // Whichever ring's next vertex comes first going round closes the next triangle.
    for (int i = 0, j = 0; i < nu || j < nl;) {
      if (j >= nl || (i < nu && (i + 1 + shift_upper) / nu <= (j + 1 + shift_lower) / nl)) {
        if (nu > 1) triangles.emplace_back(upper[i % nu], lower[j % nl], upper[(i + 1) % nu]);
        ++i;
      } else {
        if (nl > 1) triangles.emplace_back(upper[i % nu], lower[j % nl], lower[(j + 1) % nl]);
        ++j;
      }
    }
  }
  Mesh mesh;
  mesh.positions.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t v = 0; v < points.size(); ++v) mesh.positions.row(static_cast<Eigen::Index>(v)) = points[v];
  mesh.triangles.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (std::size_t t = 0; t < triangles.size(); ++t) mesh.triangles.row(static_cast<Eigen::Index>(t)) = triangles[t];
  return mesh;
}

DeformerOptions multiresolution(Eigen::Index base_vertices) {
  DeformerOptions options;
  options.resolution = Resolution::Multiresolution;
  options.base_vertices = base_vertices;
  return options;
}

}  // namespace hdeform::test

#include <algorithm>
#include <map>

#include "hdeform/laplacian.h"
#include "hdeform/mesh_check.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

constexpr ShapeKind kAll[] = {ShapeKind::Cactus, ShapeKind::Bar, ShapeKind::Cylinder, ShapeKind::Sphere};

// Every directed edge appears once and its reverse once: closed, edge-manifold, consistently oriented.
void expect_closed_oriented_manifold(const Mesh& mesh, const std::string& name) {
  std::vector<std::pair<int, int>> directed;
  directed.reserve(static_cast<std::size_t>(mesh.triangle_count()) * 3);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) directed.emplace_back(mesh.triangles(t, k), mesh.triangles(t, (k + 1) % 3));
  }
  std::sort(directed.begin(), directed.end());
  EXPECT_EQ(std::adjacent_find(directed.begin(), directed.end()), directed.end()) << name << ": a directed edge repeats";
  std::size_t unmatched = 0;
  for (const auto& [a, b] : directed) {
    if (!std::binary_search(directed.begin(), directed.end(), std::pair(b, a))) ++unmatched;
  }
  EXPECT_EQ(unmatched, 0u) << name << ": boundary or inconsistently oriented edges";
}

double signed_volume(const Mesh& mesh) {
  double volume = 0.0;
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    const Eigen::Vector3d a = mesh.positions.row(mesh.triangles(t, 0)), b = mesh.positions.row(mesh.triangles(t, 1)),
                          c = mesh.positions.row(mesh.triangles(t, 2));
    volume += a.dot(b.cross(c)) / 6.0;
  }
  return volume;
}

TEST(Shapes, AreClosedOutwardManifoldsWithOneComponent) {
  for (const auto kind : kAll) {
    for (const int resolution : {8, 13, 48}) {
      const auto shape = make_shape(kind, resolution);
      const std::string name = std::string(to_string(kind)) + "@" + std::to_string(resolution);
      expect_closed_oriented_manifold(shape.mesh, name);
      EXPECT_GT(signed_volume(shape.mesh), 0.0) << name;
      const auto weights = cotangent_weights(shape.mesh);
      const auto inspection = inspect_mesh(shape.mesh, weights);
      EXPECT_EQ(inspection.components, 1u) << name;
      EXPECT_EQ(inspection.unreferenced_vertices, 0u) << name;
      EXPECT_EQ(inspection.degenerate_triangles, 0u) << name;
      EXPECT_EQ(inspection.ignored_triangles, 0u) << name;
      EXPECT_FALSE(shape.demo_constraints.handles.at(0).empty()) << name;
      EXPECT_FALSE(shape.demo_constraints.fixed.empty()) << name;
    }
  }
}

TEST(Shapes, AreDeterministic) {
  for (const auto kind : kAll) {
    const auto a = make_shape(kind, 20), b = make_shape(kind, 20);
    EXPECT_EQ(a.mesh.positions, b.mesh.positions);
    EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
    EXPECT_EQ(a.demo_constraints.handles, b.demo_constraints.handles);
  }
}

TEST(Shapes, ReachAMillionTriangles) {
  const std::map<ShapeKind, int> resolution{{ShapeKind::Cactus, 450}, {ShapeKind::Bar, 560}, {ShapeKind::Cylinder, 600}, {ShapeKind::Sphere, 1160}};
  for (const auto& [kind, r] : resolution) {
    const auto shape = make_shape(kind, r);
    EXPECT_GE(shape.mesh.triangle_count(), 1'000'000) << to_string(kind);
    EXPECT_LE(shape.mesh.triangle_count(), 1'300'000) << to_string(kind);
    expect_closed_oriented_manifold(shape.mesh, std::string(to_string(kind)));
  }
}

TEST(Shapes, CactusHasATrunkAndTwoArms) {
  const auto shape = make_shape(ShapeKind::Cactus, 32);
  const auto& p = shape.mesh.positions;
  // Arms reach well beyond the trunk's radius on both sides (±y), and the left arm's tip (the
  // demo source) is on the −y side, above where it leaves the trunk.
  EXPECT_LT(p.col(1).minCoeff(), -0.25);
  EXPECT_GT(p.col(1).maxCoeff(), 0.2);
  EXPECT_LT(std::abs(p.col(0).maxCoeff() - 0.1), 0.01);  // the trunk bounds x
  for (const int v : shape.demo_constraints.handles[0]) {
    EXPECT_LT(p(v, 1), -0.15);
    EXPECT_GT(p(v, 2), 0.4);
  }
}

}  // namespace
}  // namespace hdeform

#include <array>
#include <algorithm>
#include <map>
#include <set>

#include "hdeform/deformer.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh_check.h"
#include "hdeform/shapes.h"
#include "hdeform/subdivision.h"
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

namespace hdeform {
namespace {

double surface_area(const Mesh& mesh) {
  double area = 0.0;
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    const Eigen::Vector3d a = mesh.positions.row(mesh.triangles(t, 0)), b = mesh.positions.row(mesh.triangles(t, 1)),
                          c = mesh.positions.row(mesh.triangles(t, 2));
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

TEST(Subdivision, SplitsEveryTriangleInPlaceKeepingTheOriginalsAndTheShape) {
  const auto shape = make_shape(ShapeKind::Cylinder, 16);
  const Mesh& mesh = shape.mesh;
  const Subdivision once = subdivide(mesh);
  const Eigen::Index edges = 3 * mesh.triangle_count() / 2;  // closed and edge-manifold
  EXPECT_EQ(once.mesh.vertex_count(), mesh.vertex_count() + edges);
  EXPECT_EQ(once.mesh.triangle_count(), 4 * mesh.triangle_count());
  EXPECT_EQ(once.mesh.positions.topRows(mesh.vertex_count()), mesh.positions);
  std::set<std::array<int, 2>> distinct(once.parents.begin(), once.parents.end());
  EXPECT_EQ(distinct.size(), once.parents.size());
  for (std::size_t i = 0; i < once.parents.size(); ++i) {
    const auto [a, b] = once.parents[i];
    EXPECT_LT(a, b);
    EXPECT_EQ(once.mesh.positions.row(mesh.vertex_count() + static_cast<Eigen::Index>(i)), 0.5 * (mesh.positions.row(a) + mesh.positions.row(b)));
  }
  // Split in their planes and oriented alike: the same area and the same enclosed volume.
  EXPECT_NEAR(surface_area(once.mesh), surface_area(mesh), 1e-12 * surface_area(mesh));
  EXPECT_NEAR(signed_volume(once.mesh), signed_volume(mesh), 1e-12 * signed_volume(mesh));
  EXPECT_GT(signed_volume(once.mesh), 0.0);
  expect_closed_oriented_manifold(once.mesh, "subdivided cylinder");
  const Subdivision twice = subdivide(once.mesh);
  EXPECT_EQ(twice.mesh.triangle_count(), 16 * mesh.triangle_count());
  // Euler characteristic of the closed cylinder, 2, at every level: V - E + F with E = 3F/2.
  EXPECT_EQ(twice.mesh.vertex_count() - 3 * twice.mesh.triangle_count() / 2 + twice.mesh.triangle_count(), 2);
}

TEST(Subdivision, ANewVertexJoinsASetWhenBothItsParentsAreInIt) {
  const auto shape = make_shape(ShapeKind::Cactus, 12);
  const Subdivision once = subdivide(shape.mesh);
  const auto constraints = subdivided_constraints(shape.demo_constraints, once);
  std::set<int> fixed(shape.demo_constraints.fixed.begin(), shape.demo_constraints.fixed.end());
  std::set<int> lifted(constraints.fixed.begin(), constraints.fixed.end());
  EXPECT_TRUE(std::is_sorted(constraints.fixed.begin(), constraints.fixed.end()));
  for (std::size_t i = 0; i < once.parents.size(); ++i) {
    const int v = static_cast<int>(once.original_vertices) + static_cast<int>(i);
    EXPECT_EQ(lifted.count(v) == 1, fixed.count(once.parents[i][0]) == 1 && fixed.count(once.parents[i][1]) == 1) << "vertex " << v;
  }
  for (const int v : fixed) EXPECT_EQ(lifted.count(v), 1u);
  // The subdivided edit deforms like any other: fixed vertices stay exactly.
  Deformer deformer(once.mesh, constraints);
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&shape.demo_transform, 1), positions);
  for (const int v : constraints.fixed) EXPECT_EQ(positions.row(v), once.mesh.positions.row(v));
}

}  // namespace
}  // namespace hdeform

// The editor's picking and selection, free of any window: the up axis a mesh stands on, the
// triangle under the cursor (against testing every triangle), the brush's balls and discs, a
// stroke's stamps, the lasso, growing and shrinking, and the one-ring adjacency.
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <thread>

#include "hdeform/engine/camera.h"
#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "gui/view_picking.h"
#include "model/mesh_picker.h"
#include "model/selection.h"
#include "test_support.h"

namespace hdeform {
namespace {
std::vector<float> snapshot_of(const Mesh& mesh) {
  engine::GeometryExchange exchange(static_cast<std::size_t>(mesh.vertex_count()));
  engine::GeometryPublisher(exchange, mesh.triangles).publish(mesh.positions);
  return exchange.acquire()->position_normal;
}

// The closest hit by testing every triangle.
std::optional<std::pair<int, float>> brute_force_pick(const Mesh& mesh, const Eigen::ParametrizedLine<float, 3>& ray) {
  std::optional<std::pair<int, float>> best;
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    const Eigen::Vector3f a = mesh.positions.row(mesh.triangles(t, 0)).cast<float>(), b = mesh.positions.row(mesh.triangles(t, 1)).cast<float>(),
                          c = mesh.positions.row(mesh.triangles(t, 2)).cast<float>();
    const Eigen::Vector3f n = (b - a).cross(c - a);
    const float denominator = n.dot(ray.direction());
    if (std::abs(denominator) < 1e-12f) continue;
    const float distance = n.dot(a - ray.origin()) / denominator;
    if (distance <= 0.0f) continue;
    const Eigen::Vector3f p = ray.pointAt(distance);
    const bool inside = (b - a).cross(p - a).dot(n) >= 0 && (c - b).cross(p - b).dot(n) >= 0 && (a - c).cross(p - c).dot(n) >= 0;
    if (inside && (!best || distance < best->second)) best = std::pair{static_cast<int>(t), distance};
  }
  return best;
}

// The up axis a mesh stands on: the cactus (modelled z-up) and the same cactus turned to stand on
// y; the shared animals (y-up, as their OBJ files come) and the Buddha (z-up).
TEST(UpAxis, IsTheAxisTheMeshStandsOn) {
  Eigen::Matrix3d z_to_y;
  z_to_y << 1, 0, 0, 0, 0, 1, 0, -1, 0;  // (x, y, z) -> (x, z, -y): what stood on z stands on y
  const Mesh cactus = make_shape(ShapeKind::Cactus, 24).mesh;
  EXPECT_EQ(engine::guess_up_axis(cactus.positions), engine::UpAxis::Z);
  EXPECT_EQ(engine::guess_up_axis(cactus.positions * z_to_y.transpose()), engine::UpAxis::Y);
  if (test::shared_meshes().empty()) GTEST_SKIP() << "../shared/meshes is absent: the real meshes are not checked";
  for (const char* name : {"horse/horse-ref.obj", "camel/camel-ref.obj", "cat/cat-ref.obj", "lion/lion-ref.obj", "armadillo/armadillo.obj"}) {
    EXPECT_EQ(engine::guess_up_axis(read_obj(test::shared_meshes() / name).positions), engine::UpAxis::Y) << name;
  }
  EXPECT_EQ(engine::guess_up_axis(read_obj(test::shared_meshes() / "buddha/buddha-51k.obj").positions), engine::UpAxis::Z);
}

TEST(MeshPicker, FindsTheSameNearestTriangleAsTestingEveryOne) {
  const Mesh mesh = make_shape(ShapeKind::Cactus, 24).mesh;
  const cli::MeshPicker picker(mesh.triangles, snapshot_of(mesh));
  std::mt19937 random(3);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  int hits = 0;
  for (int k = 0; k < 300; ++k) {
    const Eigen::Vector3f origin(1.5f * uniform(random), 1.5f * uniform(random), 0.5f + uniform(random));
    const Eigen::Vector3f target(0.1f * uniform(random), 0.3f * uniform(random), 0.45f + 0.4f * uniform(random));
    const Eigen::ParametrizedLine<float, 3> ray(origin, (target - origin).normalized());
    const auto hit = picker.pick(ray);
    const auto expected = brute_force_pick(mesh, ray);
    ASSERT_EQ(hit.has_value(), expected.has_value()) << "ray " << k;
    if (!hit) continue;
    ++hits;
    EXPECT_NEAR(hit->distance, expected->second, 1e-4f);
    EXPECT_TRUE(hit->vertex == mesh.triangles(hit->triangle, 0) || hit->vertex == mesh.triangles(hit->triangle, 1) ||
                hit->vertex == mesh.triangles(hit->triangle, 2));
  }
  EXPECT_GT(hits, 100);
}

TEST(MeshPicker, FollowsTheMeshAfterARefit) {
  Mesh mesh = make_shape(ShapeKind::Sphere, 16).mesh;
  cli::MeshPicker picker(mesh.triangles, snapshot_of(mesh));
  const Eigen::ParametrizedLine<float, 3> ray(Eigen::Vector3f(5.0f, 0.0f, 0.0f), -Eigen::Vector3f::UnitX());
  ASSERT_TRUE(picker.pick(ray));
  EXPECT_NEAR(picker.pick(ray)->distance, 4.5f, 0.01f);
  mesh.positions.col(1).array() += 3.0;  // moved out of the ray's way
  picker.refit(snapshot_of(mesh));
  EXPECT_FALSE(picker.pick(ray));
  const Eigen::ParametrizedLine<float, 3> moved_ray(Eigen::Vector3f(5.0f, 3.0f, 0.0f), -Eigen::Vector3f::UnitX());
  ASSERT_TRUE(picker.pick(moved_ray));
  EXPECT_NEAR(picker.pick(moved_ray)->distance, 4.5f, 0.01f);
}

TEST(Selection, BallLassoGrowShrinkAndConnected) {
  const int cells = 10;
  const Mesh grid = test::planar_grid(cells);
  const auto snapshot = snapshot_of(grid);
  const cli::VertexAdjacency adjacency(grid.triangles, grid.vertex_count());
  // Ball: radius just over one cell around the middle vertex: it and its 4 axis neighbours.
  const int middle = (cells / 2) * (cells + 1) + cells / 2;
  EXPECT_EQ(cli::vertices_in_ball(snapshot, grid.positions.row(middle).transpose().cast<float>(), 0.101f).size(), 5u);
  // Lasso: an orthographic-like view of the unit square filling 100×100 pixels.
  Eigen::Matrix4f view_projection = Eigen::Matrix4f::Identity();
  view_projection(0, 0) = 2.0f;
  view_projection(0, 3) = -1.0f;
  view_projection(1, 1) = 2.0f;
  view_projection(1, 3) = -1.0f;
  const std::vector<Eigen::Vector2f> square{{24, 24}, {76, 24}, {76, 76}, {24, 76}};
  const auto lassoed = cli::vertices_in_lasso(snapshot, square, view_projection, 100, 100, Eigen::Vector3f::UnitZ());
  EXPECT_EQ(lassoed.size(), 25u);  // x, y in {0.3, ..., 0.7}
  EXPECT_TRUE(cli::vertices_in_lasso(snapshot, square, view_projection, 100, 100, -Eigen::Vector3f::UnitZ()).empty());  // facing away
  std::vector<bool> one(static_cast<std::size_t>(grid.vertex_count()), false);
  one[static_cast<std::size_t>(middle)] = true;
  const auto ring = cli::grown(one, adjacency);
  EXPECT_EQ(std::count(ring.begin(), ring.end(), true), 1 + static_cast<long>(adjacency.neighbours(middle).size()));
  EXPECT_EQ(cli::shrunk(ring, adjacency), one);
  EXPECT_EQ(cli::connected_vertices(0, adjacency).size(), static_cast<std::size_t>(grid.vertex_count()));
}

// While the shape on screen keeps changing (the refinement settling), the brush's outline may pick
// on a shape up to the lag old, so that it does not refit the picker every frame; a pick that
// paints always sees the shape on screen.
TEST(ViewPicker, TheOutlineRefitsAtMostOncePerLagAndAPaintingPickAlways) {
  Mesh mesh = make_shape(ShapeKind::Sphere, 16).mesh;
  engine::GeometryExchange exchange(static_cast<std::size_t>(mesh.vertex_count()));
  engine::GeometryPublisher publisher(exchange, mesh.triangles);
  auto move_up = [&](double by) {
    mesh.positions.col(1).array() += by;
    publisher.publish(mesh.positions);
    return exchange.acquire();
  };
  auto ray_at = [](float y) { return Eigen::ParametrizedLine<float, 3>(Eigen::Vector3f(5.0f, y, 0.0f), -Eigen::Vector3f::UnitX()); };
  using Need = cli::ViewPicker::Need;
  cli::ViewPicker view(std::chrono::hours(1));
  ASSERT_NE(view.follow(mesh.triangles, move_up(0.0), Need::Exact), nullptr);
  EXPECT_TRUE(view.current()->pick(ray_at(0.0f)));
  const auto* moved = move_up(3.0);
  EXPECT_TRUE(view.follow(mesh.triangles, moved, Need::Outline)->pick(ray_at(0.0f))) << "the outline refitted within the lag";
  EXPECT_FALSE(view.follow(mesh.triangles, moved, Need::Exact)->pick(ray_at(0.0f))) << "a painting pick used an old shape";
  EXPECT_TRUE(view.current()->pick(ray_at(3.0f)));

  const auto lag = std::chrono::milliseconds(30);
  cli::ViewPicker quick(lag);
  ASSERT_NE(quick.follow(mesh.triangles, exchange.acquire(), Need::Exact), nullptr);
  moved = move_up(3.0);
  std::this_thread::sleep_for(lag + std::chrono::milliseconds(20));
  auto* outline = quick.follow(mesh.triangles, moved, Need::Outline);
  EXPECT_TRUE(outline->pick(ray_at(6.0f))) << "the outline did not catch up after the lag";
  EXPECT_FALSE(outline->pick(ray_at(3.0f)));
}

// A picker prepared in the background is built on the rest shape; the first pick, even the
// outline's, refits it to the shape on screen.
TEST(ViewPicker, APickerPreparedOnTheRestShapePicksOnTheShapeShown) {
  const auto rest = std::make_shared<const Mesh>(make_shape(ShapeKind::Sphere, 16).mesh);
  Mesh moved = *rest;
  moved.positions.col(1).array() += 3.0;
  engine::GeometryExchange exchange(static_cast<std::size_t>(moved.vertex_count()));
  engine::GeometryPublisher(exchange, moved.triangles).publish(moved.positions);
  cli::ViewPicker view(std::chrono::hours(1));
  view.prepare(rest);
  ASSERT_TRUE(view.prepared());
  const auto* picker = view.follow(rest->triangles, exchange.acquire(), cli::ViewPicker::Need::Outline);
  ASSERT_NE(picker, nullptr);
  const auto ray_at = [](float y) { return Eigen::ParametrizedLine<float, 3>(Eigen::Vector3f(5.0f, y, 0.0f), -Eigen::Vector3f::UnitX()); };
  EXPECT_TRUE(picker->pick(ray_at(3.0f))) << "the outline picked on the rest shape";
  EXPECT_FALSE(picker->pick(ray_at(0.0f)));
}

// Large enough that the halves are built in parallel (32K triangles and more): the nearest hit
// is still the one found by testing every triangle, and a refit after a move follows it.
TEST(MeshPicker, ABuildInParallelFindsWhatTestingEveryTriangleFinds) {
  Mesh mesh = test::planar_grid(160, 1.0, 0.3, 5);  // 51,200 triangles, jittered
  mesh.positions.col(2) = 0.05 * (7.0 * mesh.positions.col(0)).array().sin() * (5.0 * mesh.positions.col(1)).array().cos();
  cli::MeshPicker picker(mesh.triangles, snapshot_of(mesh));
  std::mt19937 random(11);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  for (int pass = 0; pass < 2; ++pass) {
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector3f origin(uniform(random), uniform(random), 1.0f);
      const Eigen::Vector3f target(uniform(random), uniform(random), 0.0f);
      const Eigen::ParametrizedLine<float, 3> ray(origin, (target - origin).normalized());
      const auto hit = picker.pick(ray);
      const auto expected = brute_force_pick(mesh, ray);
      ASSERT_EQ(hit.has_value(), expected.has_value()) << "pass " << pass << ", ray " << k;
      if (hit) {
        EXPECT_NEAR(hit->distance, expected->second, 1e-4f) << "pass " << pass << ", ray " << k;
      }
    }
    mesh.positions.col(2) *= -2.0;  // a new shape: the second pass picks after a refit
    picker.refit(snapshot_of(mesh));
  }
}

// A stroke's stamps lie along the path, evenly, however long its legs; the union of balls or
// discs is what testing each stamp alone and merging gives.
TEST(Selection, AStrokeIsStampedAlongItsWholePath) {
  const std::vector<Eigen::Vector2f> path{{10, 0}, {10, 0}, {10, 7}, {10.5f, 7}};
  const auto stamps = cli::stamps_along(Eigen::Vector2f(0, 0), path, 2.0f);
  // 17.5 pixels of path: a stamp every 2 of them (8) and one at the end.
  ASSERT_EQ(stamps.size(), 9u);
  EXPECT_TRUE(stamps.front().isApprox(Eigen::Vector2f(2, 0)));
  EXPECT_TRUE(stamps[4].isApprox(Eigen::Vector2f(10, 0)));
  EXPECT_TRUE(stamps[5].isApprox(Eigen::Vector2f(10, 2)));  // around the corner, 2 along the path
  EXPECT_TRUE(stamps.back().isApprox(Eigen::Vector2f(10.5f, 7)));
  for (std::size_t k = 1; k + 1 < stamps.size(); ++k) EXPECT_LE((stamps[k] - stamps[k - 1]).norm(), 2.0f + 1e-5f);
  EXPECT_TRUE(cli::stamps_along(Eigen::Vector2f(3, 3), std::vector<Eigen::Vector2f>{{3, 3}}, 2.0f).empty());  // the pointer did not move
  EXPECT_EQ(cli::stamps_along(Eigen::Vector2f(0, 0), std::vector<Eigen::Vector2f>{{1, 0}}, 2.0f).size(), 1u);  // shorter than the spacing

  const Mesh grid = test::planar_grid(60, 1.0, 0.3, 2);
  const auto snapshot = snapshot_of(grid);
  std::mt19937 random(4);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  std::vector<Eigen::Vector3f> centres;
  for (int k = 0; k < 30; ++k) centres.emplace_back(0.3f + 0.4f * uniform(random), 0.2f + 0.02f * static_cast<float>(k), 0.0f);
  std::set<int> expected;
  for (const auto& centre : centres) {
    for (int v : cli::vertices_in_ball(snapshot, centre, 0.05f)) expected.insert(v);
  }
  const auto found = cli::vertices_in_balls(snapshot, centres, 0.05f);
  EXPECT_TRUE(std::is_sorted(found.begin(), found.end()));
  EXPECT_EQ(std::set<int>(found.begin(), found.end()), expected);
  EXPECT_GT(expected.size(), 100u);

  Eigen::Matrix4f view_projection = Eigen::Matrix4f::Identity();  // the unit square onto 100×100 pixels
  view_projection(0, 0) = 2.0f;
  view_projection(0, 3) = -1.0f;
  view_projection(1, 1) = 2.0f;
  view_projection(1, 3) = -1.0f;
  std::vector<Eigen::Vector2f> discs;
  std::set<int> expected_on_screen;
  for (const auto& centre : centres) {
    discs.emplace_back(100.0f * centre.x(), 100.0f * centre.y());
    for (int v : cli::vertices_in_screen_disc(snapshot, discs.back(), 4.0f, view_projection, 100, 100)) expected_on_screen.insert(v);
  }
  const auto on_screen = cli::vertices_in_screen_discs(snapshot, discs, 4.0f, view_projection, 100, 100);
  EXPECT_EQ(std::set<int>(on_screen.begin(), on_screen.end()), expected_on_screen);
  EXPECT_GT(expected_on_screen.size(), 100u);
}

// Each vertex's one ring, sorted and without repeats, against a set of edges built in the test:
// random triangle lists with repeated corners (an edge from a vertex to itself is none),
// non-manifold edges, and vertices that no triangle uses.
TEST(Selection, AdjacencyListsEachVertexsNeighboursOnceInOrder) {
  std::mt19937 random(7);
  for (int trial = 0; trial < 20; ++trial) {
    const int vertices = 1 + static_cast<int>(random() % 60);
    const int count = static_cast<int>(random() % 120);
    Eigen::MatrixXi triangles(count, 3);
    for (int t = 0; t < count; ++t) {
      for (int k = 0; k < 3; ++k) triangles(t, k) = static_cast<int>(random() % static_cast<unsigned>(vertices));
    }
    std::vector<std::set<int>> expected(static_cast<std::size_t>(vertices));
    for (int t = 0; t < count; ++t) {
      for (int k = 0; k < 3; ++k) {
        const int a = triangles(t, k), b = triangles(t, (k + 1) % 3);
        if (a == b) continue;
        expected[static_cast<std::size_t>(a)].insert(b);
        expected[static_cast<std::size_t>(b)].insert(a);
      }
    }
    const cli::VertexAdjacency adjacency(triangles, vertices);
    ASSERT_EQ(adjacency.vertex_count(), static_cast<std::size_t>(vertices));
    for (int v = 0; v < vertices; ++v) {
      const auto ring = adjacency.neighbours(v);
      EXPECT_EQ(std::vector<int>(ring.begin(), ring.end()),
                std::vector<int>(expected[static_cast<std::size_t>(v)].begin(), expected[static_cast<std::size_t>(v)].end()))
          << "trial " << trial << ", vertex " << v;
    }
  }
}

}  // namespace
}  // namespace hdeform

// Rendering on the Vulkan device (lavapipe in CI) with the validation layer on.
#include <algorithm>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <thread>

#include "hdeform/deformer.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/errors.h"
#include "hdeform/engine/closed_mesh.h"
#include "hdeform/engine/frame_slots.h"
#include "hdeform/engine/mesh_renderer.h"
#include "hdeform/engine/offscreen.h"
#include "hdeform/engine/palette.h"
#include "hdeform/engine/proxy_mesh.h"
#include "hdeform/harmonic_field.h"
#include "hdeform/laplacian.h"
#include "hdeform/shapes.h"
#include "render_support.h"
#include "test_support.h"

namespace hdeform {
namespace {

std::vector<uint32_t> classes_of(const VertexPartition& partition) {
  std::vector<uint32_t> classes(partition.role.size(), HD_CLASS_FREE);
  for (std::size_t v = 0; v < classes.size(); ++v) {
    if (partition.role[v] == VertexRole::Fixed) classes[v] = engine::fixed_class();
    if (partition.role[v] == VertexRole::Handle) classes[v] = engine::handle_class(static_cast<std::size_t>(partition.handle_index[v]));
  }
  return classes;
}

// The cactus of the demo with its harmonic field (the paper's Figure 1, left) and, bent, its
// centre.
struct CactusScenes {
  engine::Scene field;
  engine::Scene bent;
};

CactusScenes cactus_scenes() {
  auto shape = make_shape(ShapeKind::Cactus, kDefaultShapeResolution);
  Deformer deformer(shape.mesh, shape.demo_constraints);
  Eigen::MatrixXd bent;
  deformer.deform(std::span(&shape.demo_transform, 1), bent);
  CactusScenes scenes;
  scenes.field = {shape.mesh.positions, shape.mesh.triangles, deformer.field(), classes_of(deformer.partition()), {}, {}, engine::UpAxis::Z, {}};
  scenes.bent = {bent, shape.mesh.triangles, {}, classes_of(deformer.partition()), {}, engine::Bounds::of(shape.mesh.positions), engine::UpAxis::Z, {}};
  return scenes;
}

class Render : public ::testing::Test {
 protected:
  void SetUp() override { context = test::validated_context(); }
  void TearDown() override {
    EXPECT_EQ(context->validation_message_count(), 0u) << "Vulkan validation reported problems (see stderr)";
  }
  std::unique_ptr<engine::VulkanContext> context;
};

TEST_F(Render, CactusFieldMatchesGolden) {
  test::expect_matches_golden(engine::render_offscreen(*context, cactus_scenes().field, {}), "cactus-field");
}

TEST_F(Render, BentCactusMatchesGolden) {
  test::expect_matches_golden(engine::render_offscreen(*context, cactus_scenes().bent, {}), "cactus-bent");
}

TEST_F(Render, GoldenComparisonCatchesWrongPictures) {
  const auto scenes = cactus_scenes();
  const engine::Pixels right = engine::render_offscreen(*context, scenes.field, {});
  engine::Pixels swapped = right;  // red and blue exchanged
  for (std::size_t p = 0; p < swapped.rgba.size(); p += 4) std::swap(swapped.rgba[p], swapped.rgba[p + 2]);
  engine::Shot turned;
  turned.camera = engine::Camera::three_quarter_front(engine::Bounds::of(scenes.field.positions), engine::UpAxis::Z, 1.0f);
  turned.camera->yaw += 0.2f;
  engine::Shot other_range;
  other_range.settings.field_max = 0.5f;
  engine::Scene no_mesh = scenes.field;
  no_mesh.triangles.resize(0, 3);
  for (const auto& wrong : {swapped, engine::render_offscreen(*context, scenes.field, turned), engine::render_offscreen(*context, scenes.field, other_range),
                            engine::render_offscreen(*context, no_mesh, {})}) {
    EXPECT_GT(test::compare_images(right, wrong, 24).differing_fraction, 0.005);
  }
  // ... while a render of the same scene does match.
  EXPECT_EQ(test::compare_images(right, engine::render_offscreen(*context, scenes.field, {}), 24).differing_fraction, 0.0);
}

// A unit square facing the camera, field = x: the colour bar of the picture itself.
engine::Pixels render_ramp(const engine::VulkanContext& context, float isoline_step) {
  engine::Scene scene;
  const Mesh plane = test::planar_grid(24);
  scene.positions = plane.positions;
  scene.triangles = plane.triangles;
  scene.field = plane.positions.col(0);
  scene.up = engine::UpAxis::Y;
  engine::Shot shot;
  shot.width = shot.height = 256;
  shot.settings.lighting = false;
  shot.settings.ground = false;
  shot.settings.legend = false;
  shot.settings.isoline_step = isoline_step;
  auto camera = engine::Camera::three_quarter_front(engine::Bounds::of(plane.positions), engine::UpAxis::Y, 1.0f);
  camera.yaw = camera.pitch = 0.0f;  // straight at the plane: x maps linearly to columns
  shot.camera = camera;
  return engine::render_offscreen(context, scene, shot);
}

TEST_F(Render, ColormapMapsZeroAndOneToItsEnds) {
  const engine::Pixels image = render_ramp(*context, 0.0f);
  const uint32_t row = image.height / 2;
  const Eigen::Vector3f background(engine::kBackground[0], engine::kBackground[1], engine::kBackground[2]);
  uint32_t left = 0, right = image.width - 1;
  while (left < image.width && (test::pixel(image, left, row) - background).norm() < 0.02f) ++left;
  while (right > 0 && (test::pixel(image, right, row) - background).norm() < 0.02f) --right;
  ASSERT_GT(right, left + 100) << "the plane is not where the camera should put it";
  const float span = static_cast<float>(right - left);
  for (const uint32_t x : {left + 2, left + (right - left) / 2, right - 2}) {
    const float t = (static_cast<float>(x) + 0.5f - static_cast<float>(left)) / span;
    EXPECT_LE((test::pixel(image, x, row) - engine::colormap(t)).cwiseAbs().maxCoeff(), 0.03f) << "column " << x << ", t " << t;
  }
  EXPECT_LE((test::pixel(image, left + 1, row) - engine::colormap(0.0f)).cwiseAbs().maxCoeff(), 0.03f);
  EXPECT_LE((test::pixel(image, right - 1, row) - engine::colormap(1.0f)).cwiseAbs().maxCoeff(), 0.03f);
  EXPECT_GT((engine::colormap(0.0f) - engine::colormap(1.0f)).norm(), 0.5f);
}

TEST_F(Render, IsolinesAppearWhereTheFieldCrossesTheirValues) {
  const engine::Pixels plain = render_ramp(*context, 0.0f);
  const engine::Pixels lined = render_ramp(*context, 0.25f);
  const uint32_t row = plain.height / 2;
  const Eigen::Vector3f background(engine::kBackground[0], engine::kBackground[1], engine::kBackground[2]);
  uint32_t left = 0, right = plain.width - 1;
  while ((test::pixel(plain, left, row) - background).norm() < 0.02f) ++left;
  while ((test::pixel(plain, right, row) - background).norm() < 0.02f) --right;
  const float span = static_cast<float>(right - left);
  for (const float value : {0.25f, 0.5f, 0.75f}) {
    const auto x = static_cast<uint32_t>(std::lround(static_cast<float>(left) + value * span - 0.5f));
    float darkest = 1.0f;
    for (uint32_t dx = x - 1; dx <= x + 1; ++dx) darkest = std::min(darkest, test::pixel(lined, dx, row).sum());
    EXPECT_LT(darkest, 0.5f * test::pixel(plain, x, row).sum()) << "no isoline at " << value;
    // Between the lines the colours are the plain ramp's.
    const auto between = static_cast<uint32_t>(std::lround(static_cast<float>(left) + (value - 0.125f) * span));
    EXPECT_LE((test::pixel(lined, between, row) - test::pixel(plain, between, row)).cwiseAbs().maxCoeff(), 0.02f);
  }
}

TEST_F(Render, EveryOptionRendersWithoutValidationMessages) {
  auto scene = cactus_scenes().field;
  for (const auto& position : {Eigen::Vector3f(0.1f, -0.2f, 0.5f), Eigen::Vector3f(0.0f, 0.1f, 0.7f)}) {
    scene.markers.push_back({position, 2});
  }
  engine::Shot shot;
  shot.width = 300;
  shot.height = 200;
  shot.settings.wireframe = true;
  shot.settings.flat_shading = true;
  shot.settings.back_faces = engine::RenderSettings::BackFaces::Show;
  const engine::Pixels image = engine::render_offscreen(*context, scene, shot);
  EXPECT_EQ(image.width, 300u);
  shot.samples = 1;
  shot.settings.show_classes = false;
  shot.settings.flat_shading = false;
  shot.settings.back_faces = engine::RenderSettings::BackFaces::Cull;
  engine::render_offscreen(*context, scene, shot);
}

TEST_F(Render, ABrokenMeshIsRefusedBeforeAnythingIsUploaded) {
  auto scene = cactus_scenes().bent;
  scene.triangles(11, 2) = static_cast<int>(scene.positions.rows());
  engine::Shot shot;
  shot.width = 64;
  shot.height = 48;
  EXPECT_THROW(engine::render_offscreen(*context, scene, shot), InputError);
  scene = cactus_scenes().bent;
  scene.positions(4, 0) = std::numeric_limits<double>::infinity();
  try {
    engine::render_offscreen(*context, scene, shot);
    ADD_FAILURE() << "drew a mesh with an infinite coordinate";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("vertex 4 has a non-finite coordinate x = inf"), std::string::npos) << error.what();
  }
  const auto triangles = cactus_scenes().bent.triangles;
  EXPECT_THROW(engine::VertexNormals(triangles, triangles.maxCoeff()), InputError);  // one vertex too few
}

TEST_F(Render, BackFacesOfAnOpenMeshAreTinted) {
  // The unit square seen from behind: its back face shows, in the back-face tint.
  engine::Scene scene;
  const Mesh plane = test::planar_grid(4);
  scene.positions = plane.positions;
  scene.triangles = plane.triangles;
  scene.up = engine::UpAxis::Y;
  engine::Shot shot;
  shot.width = shot.height = 64;
  shot.settings.ground = false;
  shot.settings.lighting = false;
  auto camera = engine::Camera::three_quarter_front(engine::Bounds::of(plane.positions), engine::UpAxis::Y, 1.0f);
  camera.yaw = camera.pitch = 0.0f;
  shot.camera = camera;
  const Eigen::Vector3f front = test::pixel(engine::render_offscreen(*context, scene, shot), 32, 32);
  shot.camera->yaw = static_cast<float>(std::numbers::pi);
  const Eigen::Vector3f back = test::pixel(engine::render_offscreen(*context, scene, shot), 32, 32);
  EXPECT_GT((front - back).norm(), 0.15f);
  EXPECT_GT(back.x(), back.y());  // the tint is purple-red
}

TEST_F(Render, VerticesWithTheirOwnColourShowIt) {
  // The square's left half in one colour, its right half in another (the correspondence picture
  // colours each triangle this way).
  engine::Scene scene;
  const Mesh plane = test::planar_grid(8);
  scene.positions = plane.positions;
  scene.triangles = plane.triangles;
  scene.up = engine::UpAxis::Y;
  const Eigen::Vector3f orange(1.0f, 0.5f, 0.0f), teal(0.0f, 0.5f, 0.5f);
  for (Eigen::Index v = 0; v < plane.vertex_count(); ++v) scene.classes.push_back(engine::color_class(plane.positions(v, 0) < 0.5 ? orange : teal));
  engine::Shot shot;
  shot.width = shot.height = 64;
  shot.settings.ground = false;
  shot.settings.lighting = false;
  auto camera = engine::Camera::three_quarter_front(engine::Bounds::of(plane.positions), engine::UpAxis::Y, 1.0f);
  camera.yaw = camera.pitch = 0.0f;
  shot.camera = camera;
  const engine::Pixels image = engine::render_offscreen(*context, scene, shot);
  EXPECT_LE((test::pixel(image, 16, 32) - orange).cwiseAbs().maxCoeff(), 0.02f);
  EXPECT_LE((test::pixel(image, 48, 32) - teal).cwiseAbs().maxCoeff(), 0.02f);
}

// The proxy drawn while a large mesh moves: triangles over the mesh's own vertices, about as many
// as asked for, the surface kept (closed stays closed, area within 1%), nothing for a mesh that
// is small already. Both ways: the edge collapses alone, and after clustering on a grid (a mesh
// of more than 16 times the target).
TEST(ProxyMesh, FewerTrianglesOverTheSameVerticesAndTheSameSurface) {
  const Mesh sphere = make_shape(ShapeKind::Sphere, 240).mesh;
  ASSERT_GT(sphere.triangle_count(), 40000);
  auto area = [&](const Eigen::MatrixXi& triangles) {
    double sum = 0.0;
    for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
      const Eigen::Vector3d a = sphere.positions.row(triangles(t, 0)), b = sphere.positions.row(triangles(t, 1)), c = sphere.positions.row(triangles(t, 2));
      sum += 0.5 * (b - a).cross(c - a).norm();
    }
    return sum;
  };
  const Eigen::Index clustered_target = sphere.triangle_count() / 40, direct_target = sphere.triangle_count() / 8;
  for (const Eigen::Index target : {clustered_target, direct_target}) {
    SCOPED_TRACE("target " + std::to_string(target) + " of " + std::to_string(sphere.triangle_count()));
    const Eigen::MatrixXi proxy = engine::proxy_triangles(sphere.triangles, sphere.positions, target);
    EXPECT_GT(proxy.rows(), target * 3 / 4);
    EXPECT_LE(proxy.rows(), target);
    EXPECT_NO_THROW(validate_triangles(proxy, sphere.vertex_count()));
    EXPECT_NEAR(area(proxy) / area(sphere.triangles), 1.0, 0.01);
    std::set<std::pair<int, int>> directed;
    for (Eigen::Index t = 0; t < proxy.rows(); ++t) {
      for (int k = 0; k < 3; ++k) directed.insert({proxy(t, k), proxy(t, (k + 1) % 3)});
    }
    for (const auto& [from, to] : directed) EXPECT_TRUE(directed.count({to, from})) << from << " → " << to << " has no twin";
  }
  EXPECT_EQ(engine::proxy_triangles(sphere.triangles, sphere.positions, sphere.triangle_count() / 2).rows(), 0);
}

// Closed for drawing (back faces never in view): a sphere is; without one triangle, or with one
// turned over, it is not. And on random triangle lists, the answer of a set of directed edges
// built in the test.
TEST(ClosedMesh, EveryEdgeHasItsReverseOrNot) {
  const Mesh sphere = make_shape(ShapeKind::Sphere, 24).mesh;
  EXPECT_TRUE(engine::every_edge_has_its_reverse(sphere.triangles, sphere.vertex_count()));
  Eigen::MatrixXi open = sphere.triangles.topRows(sphere.triangle_count() - 1);
  EXPECT_FALSE(engine::every_edge_has_its_reverse(open, sphere.vertex_count()));
  Eigen::MatrixXi turned = sphere.triangles;
  std::swap(turned(5, 1), turned(5, 2));
  EXPECT_FALSE(engine::every_edge_has_its_reverse(turned, sphere.vertex_count()));
  EXPECT_FALSE(engine::every_edge_has_its_reverse(Eigen::MatrixXi(0, 3), 4));
  std::mt19937 random(11);
  int closed_lists = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int vertices = 3 + static_cast<int>(random() % 5);
    Eigen::MatrixXi triangles(1 + static_cast<int>(random() % 8), 3);
    for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
      for (int k = 0; k < 3; ++k) triangles(t, k) = static_cast<int>(random() % static_cast<unsigned>(vertices));
    }
    std::set<std::pair<int, int>> directed;
    for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
      for (int k = 0; k < 3; ++k) directed.insert({triangles(t, k), triangles(t, (k + 1) % 3)});
    }
    const bool expected = std::all_of(directed.begin(), directed.end(), [&](const auto& edge) { return directed.count({edge.second, edge.first}) > 0; });
    closed_lists += expected ? 1 : 0;
    EXPECT_EQ(engine::every_edge_has_its_reverse(triangles, vertices), expected) << "trial " << trial;
  }
  EXPECT_GT(closed_lists, 0);  // the random lists reach both answers
}

// Drawn with the proxy, the picture is nearly the mesh's; without the setting, exactly the mesh's.
TEST_F(Render, TheProxyDrawsNearlyTheMeshesPicture) {
  const Mesh sphere = make_shape(ShapeKind::Sphere, 240).mesh;
  engine::Scene scene;
  scene.positions = sphere.positions;
  scene.triangles = sphere.triangles;
  scene.field = sphere.positions.col(2);
  engine::Shot shot;
  shot.width = shot.height = 256;
  const engine::Pixels full = engine::render_offscreen(*context, scene, shot);
  scene.proxy_triangles = engine::proxy_triangles(sphere.triangles, sphere.positions, 4000);
  EXPECT_EQ(test::compare_images(full, engine::render_offscreen(*context, scene, shot), 0).differing_fraction, 0.0);
  shot.settings.proxy = true;
  const engine::Pixels proxy = engine::render_offscreen(*context, scene, shot);
  EXPECT_LT(test::compare_images(full, proxy, 24).differing_fraction, 0.02);
  // A proxy that dropped half the surface is caught.
  scene.proxy_triangles.conservativeResize(scene.proxy_triangles.rows() / 2, 3);
  EXPECT_GT(test::compare_images(full, engine::render_offscreen(*context, scene, shot), 24).differing_fraction, 0.05);
}

TEST(GeometryExchange, TheReaderGetsTheNewestPublicationWithoutWaiting) {
  engine::GeometryExchange exchange(2);
  EXPECT_EQ(exchange.acquire(), nullptr);
  for (float value : {1.0f, 2.0f, 3.0f}) {
    std::fill(exchange.back().position_normal.begin(), exchange.back().position_normal.end(), value);
    exchange.publish();
  }
  const auto* newest = exchange.acquire();
  ASSERT_NE(newest, nullptr);
  EXPECT_EQ(newest->position_normal[0], 3.0f);
  EXPECT_EQ(newest->version, 3u);
  EXPECT_EQ(exchange.acquire(), newest);  // nothing new: the same snapshot again
  std::fill(exchange.back().position_normal.begin(), exchange.back().position_normal.end(), 4.0f);
  exchange.publish();
  EXPECT_EQ(exchange.acquire()->position_normal[0], 4.0f);
}

TEST(GeometryExchange, AReaderOnAnotherThreadNeverSeesATornOrOlderSnapshot) {
  // The solver and the render thread as they run in the editor: every publication fills the
  // whole buffer with its version, so a snapshot mixing two publications, or one reused while
  // the writer fills it, shows two values. Under ThreadSanitizer this is the handoff's race check.
  constexpr std::uint64_t kPublications = 20000;
  engine::GeometryExchange exchange(256);
  std::thread writer([&] {
    for (std::uint64_t version = 1; version <= kPublications; ++version) {
      auto& back = exchange.back();
      std::fill(back.position_normal.begin(), back.position_normal.end(), static_cast<float>(version));
      back.tag = version;
      exchange.publish();
    }
  });
  std::uint64_t last_seen = 0, distinct_seen = 0, torn = 0;
  while (last_seen < kPublications) {
    const auto* snapshot = exchange.acquire();
    if (snapshot == nullptr) continue;
    ASSERT_GE(snapshot->version, last_seen) << "an older publication came back";
    ASSERT_EQ(snapshot->tag, snapshot->version);
    const float expected = static_cast<float>(snapshot->version);
    torn += static_cast<std::uint64_t>(std::count_if(snapshot->position_normal.begin(), snapshot->position_normal.end(),
                                                     [&](float value) { return value != expected; }));
    if (snapshot->version > last_seen) ++distinct_seen;
    last_seen = snapshot->version;
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(last_seen, kPublications);
  std::printf("reader saw %llu of %llu publications\n", static_cast<unsigned long long>(distinct_seen),
              static_cast<unsigned long long>(kPublications));
}

TEST_F(Render, TheNextFrameShowsTheLatestOfTwoPublications) {
  // Publish twice between frames: the frame shows the second positions, not the first.
  auto shape = make_shape(ShapeKind::Sphere, 16);
  engine::OffscreenTarget target(*context, 128, 128, 1);
  engine::FrameSlots slots(*context, 1);
  engine::MeshRenderer renderer(*context, target.render_pass(), target.format(), 1);
  engine::GeometryExchange exchange(static_cast<std::size_t>(shape.mesh.vertex_count()));
  engine::GeometryPublisher publisher(exchange, shape.mesh.triangles);
  const engine::Bounds bounds{Eigen::Vector3f(-1.5f, -1.5f, -0.5f), Eigen::Vector3f(1.5f, 1.5f, 0.5f)};
  renderer.set_mesh(shape.mesh.triangles, exchange, bounds, engine::UpAxis::Z);
  auto camera = engine::Camera::three_quarter_front(bounds, engine::UpAxis::Z, 1.0f);
  camera.yaw = 0.0f;
  camera.pitch = 1.5f;  // from above: +y is to the right... of the picture's columns
  engine::RenderSettings settings;
  settings.ground = false;
  auto frame = [&] { return test::draw_frame(renderer, slots, target, camera, settings); };
  // Column of the mesh's centre of coverage.
  auto centre_column = [&](const engine::Pixels& image) {
    const Eigen::Vector3f background(engine::kBackground[0], engine::kBackground[1], engine::kBackground[2]);
    double sum = 0.0, count = 0.0;
    for (uint32_t y = 0; y < image.height; ++y) {
      for (uint32_t x = 0; x < image.width; ++x) {
        if ((test::pixel(image, x, y) - background).norm() > 0.05f) {
          sum += x;
          ++count;
        }
      }
    }
    return count > 0 ? sum / count : -1.0;
  };
  Eigen::MatrixXd left = shape.mesh.positions, right = shape.mesh.positions;
  left.col(1).array() -= 0.8;
  right.col(1).array() += 0.8;
  publisher.publish(left);
  const double first = centre_column(frame());
  publisher.publish(left);
  publisher.publish(right);  // two publications before the next frame
  const double second = centre_column(frame());
  EXPECT_EQ(renderer.drawn_geometry_version(), 3u);
  EXPECT_GT(std::abs(second - first), 20.0) << "the frame did not show the newest publication";
}

// A drag on a large mesh publishes the proxy's vertices alone: those, each with the very bits a
// whole publication gives it, and the snapshot says which they are; a whole publication after it
// is whole again, and without a proxy a proxy publication is whole.
TEST(GeometryPublisher, AProxyPublicationWritesTheProxysVerticesAsAWholeOneWould) {
  const Mesh sphere = make_shape(ShapeKind::Sphere, 120).mesh;
  const Eigen::MatrixXi proxy = engine::proxy_triangles(sphere.triangles, sphere.positions, 2000);
  ASSERT_GT(proxy.rows(), 0);
  std::vector<int> proxy_vertices(proxy.data(), proxy.data() + proxy.size());
  std::sort(proxy_vertices.begin(), proxy_vertices.end());
  proxy_vertices.erase(std::unique(proxy_vertices.begin(), proxy_vertices.end()), proxy_vertices.end());
  Eigen::MatrixXd moved = sphere.positions;
  for (Eigen::Index v = 0; v < moved.rows(); ++v) moved.row(v) += Eigen::RowVector3d(0.3 * moved(v, 2) * moved(v, 2), 0.1, -0.2);

  const auto n = static_cast<std::size_t>(sphere.vertex_count());
  engine::GeometryExchange whole_exchange(n), exchange(n);
  engine::GeometryPublisher whole(whole_exchange, sphere.triangles), publisher(exchange, sphere.triangles);
  whole.publish(moved, 7);
  const std::vector<float> reference = whole_exchange.acquire()->position_normal;

  publisher.set_proxy(proxy);
  publisher.publish(sphere.positions, 1);
  EXPECT_EQ(exchange.acquire()->only_vertices, nullptr);
  publisher.publish(moved, 2, engine::GeometryPublisher::Detail::Proxy);
  const engine::GeometrySnapshot* snapshot = exchange.acquire();
  ASSERT_NE(snapshot, nullptr);
  EXPECT_EQ(snapshot->tag, 2u);
  ASSERT_NE(snapshot->only_vertices, nullptr);
  EXPECT_EQ(*snapshot->only_vertices, proxy_vertices);
  ASSERT_NE(publisher.proxy_vertices(), nullptr);
  EXPECT_EQ(*publisher.proxy_vertices(), proxy_vertices);
  std::size_t differing = 0;
  for (const int v : proxy_vertices) {
    for (int c = 0; c < 6; ++c) differing += snapshot->position_normal[6 * static_cast<std::size_t>(v) + c] != reference[6 * static_cast<std::size_t>(v) + c];
  }
  EXPECT_EQ(differing, 0u);

  publisher.publish(moved, 3);
  snapshot = exchange.acquire();
  EXPECT_EQ(snapshot->only_vertices, nullptr);
  EXPECT_EQ(snapshot->position_normal, reference);

  publisher.set_proxy(Eigen::MatrixXi(0, 3));
  EXPECT_EQ(publisher.proxy_vertices(), nullptr);
  publisher.publish(moved, 4, engine::GeometryPublisher::Detail::Proxy);
  EXPECT_EQ(exchange.acquire()->only_vertices, nullptr);
  EXPECT_EQ(exchange.acquire()->position_normal, reference);
}

// A settling shape goes out with every vertex's position and the proxy's normals alone: every
// position and the proxy's vertices with the very bits a whole publication gives them, the
// snapshot drawn as the proxy yet the whole shape to pick on; a drag's proxy publication is not,
// a whole one after it is whole again, and without a proxy a settling publication is whole.
TEST(GeometryPublisher, ASettlingPublicationWritesEveryPositionAndTheProxysNormals) {
  const Mesh sphere = make_shape(ShapeKind::Sphere, 120).mesh;
  const Eigen::MatrixXi proxy = engine::proxy_triangles(sphere.triangles, sphere.positions, 2000);
  ASSERT_GT(proxy.rows(), 0);
  Eigen::MatrixXd moved = sphere.positions;
  for (Eigen::Index v = 0; v < moved.rows(); ++v) moved.row(v) += Eigen::RowVector3d(0.3 * moved(v, 2) * moved(v, 2), 0.1, -0.2);
  const auto n = static_cast<std::size_t>(sphere.vertex_count());
  engine::GeometryExchange whole_exchange(n), exchange(n);
  engine::GeometryPublisher(whole_exchange, sphere.triangles).publish(moved);
  const std::vector<float> reference = whole_exchange.acquire()->position_normal;

  engine::GeometryPublisher publisher(exchange, sphere.triangles);
  publisher.set_proxy(proxy);
  for (std::uint64_t tag = 1; tag <= 3; ++tag) publisher.publish(sphere.positions, tag);  // every slot at rest
  publisher.publish(moved, 4, engine::GeometryPublisher::Detail::ProxyNormals);
  const engine::GeometrySnapshot* snapshot = exchange.acquire();
  ASSERT_NE(snapshot, nullptr);
  EXPECT_EQ(snapshot->tag, 4u);
  ASSERT_NE(snapshot->only_vertices, nullptr);
  EXPECT_EQ(*snapshot->only_vertices, *publisher.proxy_vertices());
  EXPECT_TRUE(snapshot->every_position);
  std::size_t positions_differing = 0, proxy_differing = 0, normals_left = 0;
  for (std::size_t v = 0; v < n; ++v) {
    for (std::size_t c = 0; c < 3; ++c) positions_differing += snapshot->position_normal[6 * v + c] != reference[6 * v + c];
  }
  for (const int v : *snapshot->only_vertices) {
    for (std::size_t c = 0; c < 6; ++c) proxy_differing += snapshot->position_normal[6 * static_cast<std::size_t>(v) + c] != reference[6 * static_cast<std::size_t>(v) + c];
  }
  // The other vertices' normals are the rest shape's still: not worked out.
  std::vector<bool> in_proxy(n, false);
  for (const int v : *snapshot->only_vertices) in_proxy[static_cast<std::size_t>(v)] = true;
  for (std::size_t v = 0; v < n; ++v) {
    if (in_proxy[v]) continue;
    normals_left += snapshot->position_normal[6 * v + 3] != reference[6 * v + 3];
  }
  EXPECT_EQ(positions_differing, 0u);
  EXPECT_EQ(proxy_differing, 0u);
  EXPECT_GT(normals_left, (n - snapshot->only_vertices->size()) / 2) << "the normals of every vertex were worked out";

  publisher.publish(moved, 5, engine::GeometryPublisher::Detail::Proxy);
  EXPECT_FALSE(exchange.acquire()->every_position) << "a drag's answer holds the proxy's positions alone";
  publisher.publish(moved, 6);
  EXPECT_EQ(exchange.acquire()->only_vertices, nullptr);
  EXPECT_TRUE(exchange.acquire()->every_position);
  EXPECT_EQ(exchange.acquire()->position_normal, reference);

  publisher.set_proxy(Eigen::MatrixXi(0, 3));
  publisher.publish(moved, 7, engine::GeometryPublisher::Detail::ProxyNormals);
  EXPECT_EQ(exchange.acquire()->only_vertices, nullptr);
  EXPECT_EQ(exchange.acquire()->position_normal, reference);
}

// Shared triangles publish what copied ones do, and the normals are the area-weighted ones,
// summed here triangle by triangle (another order, so to float precision).
TEST(GeometryPublisher, SharedTrianglesPublishAreaWeightedNormals) {
  const auto mesh = std::make_shared<const Mesh>(make_shape(ShapeKind::Cactus, 24).mesh);
  Eigen::MatrixXd moved = mesh->positions;
  for (Eigen::Index v = 0; v < moved.rows(); ++v) moved.row(v) += Eigen::RowVector3d(0.2 * moved(v, 2) * moved(v, 2), 0.0, 0.1 * moved(v, 0));
  const auto n = static_cast<std::size_t>(mesh->vertex_count());
  engine::GeometryExchange copied_exchange(n), shared_exchange(n);
  engine::GeometryPublisher(copied_exchange, mesh->triangles).publish(moved);
  engine::GeometryPublisher(shared_exchange, std::shared_ptr<const Eigen::MatrixXi>(mesh, &mesh->triangles)).publish(moved);
  const auto& published = shared_exchange.acquire()->position_normal;
  EXPECT_EQ(published, copied_exchange.acquire()->position_normal);
  Eigen::MatrixXd normals = Eigen::MatrixXd::Zero(mesh->vertex_count(), 3);
  for (Eigen::Index t = 0; t < mesh->triangle_count(); ++t) {
    const Eigen::Vector3d a = moved.row(mesh->triangles(t, 0)), b = moved.row(mesh->triangles(t, 1)), c = moved.row(mesh->triangles(t, 2));
    const Eigen::RowVector3d area_normal = (b - a).cross(c - a).transpose();
    for (int k = 0; k < 3; ++k) normals.row(mesh->triangles(t, k)) += area_normal;
  }
  for (Eigen::Index v = 0; v < mesh->vertex_count(); ++v) {
    const Eigen::RowVector3d expected = normals.row(v).normalized();
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(published[6 * static_cast<std::size_t>(v) + static_cast<std::size_t>(c)], static_cast<float>(moved(v, c)));
      EXPECT_NEAR(published[6 * static_cast<std::size_t>(v) + 3 + static_cast<std::size_t>(c)], expected(c), 1e-6) << "vertex " << v;
    }
  }
}

// A snapshot of the proxy's vertices alone is drawn as the proxy whatever the settings: the
// same picture as the proxy of a whole publication, never the mesh with the other vertices where
// an older publication left them.
TEST_F(Render, AProxyPublicationIsDrawnAsTheProxy) {
  const Mesh sphere = make_shape(ShapeKind::Sphere, 120).mesh;
  const Eigen::MatrixXi proxy = engine::proxy_triangles(sphere.triangles, sphere.positions, 2000);
  ASSERT_GT(proxy.rows(), 0);
  engine::OffscreenTarget target(*context, 128, 128, 1);
  engine::FrameSlots slots(*context, 1);
  engine::MeshRenderer renderer(*context, target.render_pass(), target.format(), 1);
  engine::GeometryExchange exchange(static_cast<std::size_t>(sphere.vertex_count()));
  engine::GeometryPublisher publisher(exchange, sphere.triangles);
  const engine::Bounds bounds{Eigen::Vector3f(-1.5f, -1.5f, -1.5f), Eigen::Vector3f(1.5f, 1.5f, 1.5f)};
  renderer.set_mesh(sphere.triangles, exchange, bounds, engine::UpAxis::Z);
  renderer.set_proxy(proxy);
  publisher.set_proxy(proxy);
  const auto camera = engine::Camera::three_quarter_front(bounds, engine::UpAxis::Z, 1.0f);
  auto frame = [&](bool proxy_setting) {
    engine::RenderSettings settings;
    settings.ground = false;
    settings.proxy = proxy_setting;
    return test::draw_frame(renderer, slots, target, camera, settings);
  };
  Eigen::MatrixXd moved = sphere.positions;
  moved.col(1).array() += 0.6;
  publisher.publish(moved);
  const engine::Pixels proxy_of_whole = frame(true);
  EXPECT_TRUE(renderer.prepared_proxy());
  const engine::Pixels whole = frame(false);
  EXPECT_FALSE(renderer.prepared_proxy());

  publisher.publish(sphere.positions);  // every vertex elsewhere
  frame(false);
  publisher.publish(moved, 0, engine::GeometryPublisher::Detail::Proxy);
  const engine::Pixels proxy_only = frame(false);
  EXPECT_TRUE(renderer.prepared_proxy());
  EXPECT_EQ(test::compare_images(proxy_of_whole, proxy_only, 0).differing_fraction, 0.0);
  EXPECT_GT(test::compare_images(whole, proxy_only, 0).differing_fraction, 0.0);  // the proxy, not the mesh
}

// A picture's parts with a ramp: the first ones double up to the size of the others.
TEST(DrawSlice, ARampsPartsDoubleUpToTheOthers) {
  // Parts of 1, 2, 4, 8, 8, 8, 8 units: 39 in all.
  const double expected[] = {0, 1, 3, 7, 15, 23, 31, 39};
  for (int k = 0; k <= 7; ++k) EXPECT_DOUBLE_EQ(engine::share_before({k, 7, 3}), expected[k] / 39.0) << "part " << k;
  for (int k = 0; k <= 5; ++k) EXPECT_DOUBLE_EQ(engine::share_before({k, 5, 0}), k / 5.0) << "no ramp: equal parts";
}

TEST(VulkanContext, AnUnknownDeviceIsAClearError) {
  engine::ContextOptions options;
  options.device = "no-such-device-anywhere";
  options.announce = false;
  try {
    engine::VulkanContext context(options);
    FAIL() << "no error";
  } catch (const engine::RenderError& error) {
    EXPECT_NE(std::string(error.what()).find("no Vulkan device matches 'no-such-device-anywhere'"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("devices:"), std::string::npos);
  }
  options.device = "cpu";
  const engine::VulkanContext cpu(options);
  EXPECT_TRUE(cpu.is_cpu_device());
}

}  // namespace
}  // namespace hdeform

// A mesh's buffers made and written before the renderer takes them (mesh_buffers.h), with the
// validation layer on.
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "hdeform/errors.h"
#include "hdeform/engine/closed_mesh.h"
#include "hdeform/engine/mesh_buffers.h"
#include "hdeform/shapes.h"
#include "render_support.h"
#include "test_support.h"

namespace hdeform {
namespace {

// One renderer drawing into a small offscreen target, one frame in flight.
struct Drawing {
  explicit Drawing(const engine::VulkanContext& context)
      : target(context, 128, 128, 1), slots(context, 1), renderer(context, target.render_pass(), target.format(), 1) {}
  engine::Pixels frame() {
    engine::RenderSettings settings;
    settings.ground = false;
    return test::draw_frame(renderer, slots, target, camera, settings);
  }
  static inline const engine::Bounds bounds{Eigen::Vector3f(-1.5f, -1.5f, -1.5f), Eigen::Vector3f(1.5f, 1.5f, 1.5f)};
  engine::OffscreenTarget target;
  engine::FrameSlots slots;
  engine::MeshRenderer renderer;
  engine::Camera camera = engine::Camera::three_quarter_front(bounds, engine::UpAxis::Z, 1.0f);
};

class MeshBuffersTest : public ::testing::Test {
 protected:
  void SetUp() override { context = test::validated_context(); }
  void TearDown() override {
    EXPECT_EQ(context->validation_message_count(), 0u) << "Vulkan validation reported problems (see stderr)";
  }
  std::unique_ptr<engine::MeshBuffers> buffers_for(const Mesh& mesh, uint32_t frames = 1) const {
    return std::make_unique<engine::MeshBuffers>(*context, static_cast<std::size_t>(mesh.vertex_count()),
                                                 static_cast<std::size_t>(mesh.triangle_count()), frames);
  }
  std::unique_ptr<engine::VulkanContext> context;
  const Mesh sphere = make_shape(ShapeKind::Sphere, 120).mesh;
};

// Written on another thread from the published snapshot, the buffers draw the picture of a mesh
// set directly, and the first frame draws the geometry they hold without uploading it again: a
// snapshot of other positions under the published one's version is what shows.
TEST_F(MeshBuffersTest, BuffersWrittenOnAnotherThreadDrawTheMeshAndItsFirstFrameUploadsNothing) {
  const bool closed = engine::every_edge_has_its_reverse(sphere.triangles, sphere.vertex_count());
  Eigen::MatrixXd moved = sphere.positions;
  moved.col(1).array() += 0.5;

  Drawing direct(*context);
  engine::GeometryExchange direct_exchange(static_cast<std::size_t>(sphere.vertex_count()));
  engine::GeometryPublisher(direct_exchange, sphere.triangles).publish(moved);
  direct.renderer.set_mesh(sphere.triangles, direct_exchange, Drawing::bounds, engine::UpAxis::Z);
  const engine::Pixels expected = direct.frame();

  Drawing staged(*context);
  engine::GeometryExchange exchange(static_cast<std::size_t>(sphere.vertex_count()));
  engine::GeometryPublisher(exchange, sphere.triangles).publish(moved);
  auto buffers = buffers_for(sphere);
  const engine::GeometrySnapshot* snapshot = exchange.acquire();
  ASSERT_NE(snapshot, nullptr);
  std::vector<double> shares;
  bool written = false;
  std::thread([&] { written = buffers->fill(sphere.triangles, snapshot, [&](double share) { shares.push_back(share); return true; }); }).join();
  ASSERT_TRUE(written);
  EXPECT_TRUE(buffers->filled());
  ASSERT_FALSE(shares.empty());
  for (std::size_t k = 1; k < shares.size(); ++k) EXPECT_LE(shares[k - 1], shares[k]);
  EXPECT_DOUBLE_EQ(shares.back(), 1.0);
  staged.renderer.set_mesh(std::move(buffers), exchange, Drawing::bounds, engine::UpAxis::Z, closed);
  EXPECT_EQ(test::compare_images(expected, staged.frame(), 0).differing_fraction, 0.0);

  // The rest shape written under the version of the moved one: the renderer takes the exchange's
  // snapshot of that version as drawn already.
  Drawing rest(*context);
  engine::GeometryExchange rest_exchange(static_cast<std::size_t>(sphere.vertex_count()));
  engine::GeometryPublisher rest_publisher(rest_exchange, sphere.triangles);
  rest_publisher.publish(moved);
  const engine::GeometrySnapshot* published = rest_exchange.acquire();
  engine::GeometrySnapshot at_rest;
  at_rest.position_normal.resize(published->position_normal.size());
  engine::VertexNormals(sphere.triangles, sphere.vertex_count()).write(sphere.positions, at_rest);
  at_rest.version = published->version;
  auto rest_buffers = buffers_for(sphere);
  ASSERT_TRUE(rest_buffers->fill(sphere.triangles, &at_rest));
  rest.renderer.set_mesh(std::move(rest_buffers), rest_exchange, Drawing::bounds, engine::UpAxis::Z, closed);
  const engine::Pixels first = rest.frame();
  EXPECT_GT(test::compare_images(expected, first, 0).differing_fraction, 0.01) << "the first frame uploaded the snapshot again";
  rest_publisher.publish(moved);  // a new version: uploaded
  EXPECT_EQ(test::compare_images(expected, rest.frame(), 0).differing_fraction, 0.0);
}

// Stopped partway, or refused for a triangle with a vertex out of range (named), the buffers are
// not taken and the renderer draws the mesh it had; so are buffers made for other frames.
TEST_F(MeshBuffersTest, UnfinishedOrBadBuffersAreRefusedAndTheMeshDrawnStays) {
  const Mesh bar = make_shape(ShapeKind::Bar, 8).mesh;
  Drawing drawing(*context);
  engine::GeometryExchange exchange(static_cast<std::size_t>(sphere.vertex_count()));
  engine::GeometryPublisher(exchange, sphere.triangles).publish(sphere.positions);
  drawing.renderer.set_mesh(sphere.triangles, exchange, Drawing::bounds, engine::UpAxis::Z);
  const engine::Pixels before = drawing.frame();

  engine::GeometryExchange bar_exchange(static_cast<std::size_t>(bar.vertex_count()));
  engine::GeometryPublisher(bar_exchange, bar.triangles).publish(bar.positions);
  const engine::GeometrySnapshot* snapshot = bar_exchange.acquire();

  auto stopped = buffers_for(bar);
  int calls = 0;
  EXPECT_FALSE(stopped->fill(bar.triangles, snapshot, [&](double) { return ++calls < 2; }));
  EXPECT_EQ(calls, 2);
  EXPECT_FALSE(stopped->filled());
  EXPECT_THROW(drawing.renderer.set_mesh(std::move(stopped), bar_exchange, Drawing::bounds, engine::UpAxis::Z, true), std::logic_error);

  Eigen::MatrixXi broken = bar.triangles;
  broken(7, 1) = static_cast<int>(bar.vertex_count());
  auto refused = buffers_for(bar);
  try {
    refused->fill(broken, snapshot);
    ADD_FAILURE() << "wrote a triangle with a vertex out of range";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("triangle 7 corner 1"), std::string::npos) << error.what();
  }
  EXPECT_FALSE(refused->filled());
  EXPECT_THROW(refused->fill(bar.triangles.topRows(3), snapshot), InputError);  // not the count made for

  auto two_frames = buffers_for(bar, 2);
  ASSERT_TRUE(two_frames->fill(bar.triangles, snapshot));
  EXPECT_THROW(drawing.renderer.set_mesh(std::move(two_frames), bar_exchange, Drawing::bounds, engine::UpAxis::Z, true), std::logic_error);
  auto other_vertices = buffers_for(bar);
  ASSERT_TRUE(other_vertices->fill(bar.triangles, snapshot));
  EXPECT_THROW(drawing.renderer.set_mesh(std::move(other_vertices), exchange, Drawing::bounds, engine::UpAxis::Z, true), std::logic_error);

  EXPECT_EQ(test::compare_images(before, drawing.frame(), 0).differing_fraction, 0.0);
}

}  // namespace
}  // namespace hdeform

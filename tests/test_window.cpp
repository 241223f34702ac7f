// The same drawing code in a GLFW window (run under Xvfb by ctest): the window's picture equals
// the offscreen one, and resizing and minimising keep the swapchain valid.
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include "hdeform/engine/frame_slots.h"
#include "hdeform/engine/mesh_renderer.h"
#include "hdeform/engine/offscreen.h"
#include "hdeform/engine/swapchain_target.h"
#include "hdeform/shapes.h"
#include "render_support.h"
#include "test_support.h"

namespace hdeform {
namespace {

class Window : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no X display (ctest runs this under xvfb-run)";
    ASSERT_TRUE(glfwInit()) << "GLFW could not start";
    ASSERT_TRUE(glfwVulkanSupported());
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    window = glfwCreateWindow(320, 240, "hdeform test", nullptr, nullptr);
    ASSERT_NE(window, nullptr);
    engine::ContextOptions options;
    options.validation = true;
    options.announce = false;
    uint32_t count = 0;
    const char** extensions = glfwGetRequiredInstanceExtensions(&count);
    options.instance_extensions.assign(extensions, extensions + count);
    options.create_surface = [this](VkInstance instance) {
      VkSurfaceKHR surface = VK_NULL_HANDLE;
      engine::check(glfwCreateWindowSurface(instance, window, nullptr, &surface), "glfwCreateWindowSurface");
      return surface;
    };
    context = std::make_unique<engine::VulkanContext>(options);
  }
  void TearDown() override {
    if (context) {
      EXPECT_EQ(context->validation_message_count(), 0u) << "Vulkan validation reported problems (see stderr)";
    }
    context.reset();
    if (window != nullptr) glfwDestroyWindow(window);
    glfwTerminate();
  }
  VkExtent2D framebuffer_size() const {
    int width = 0, height = 0;
    glfwGetFramebufferSize(window, &width, &height);
    return {static_cast<uint32_t>(width), static_cast<uint32_t>(height)};
  }

  GLFWwindow* window = nullptr;
  std::unique_ptr<engine::VulkanContext> context;
};

TEST_F(Window, ShowsWhatTheOffscreenTargetShowsAndSurvivesResizeAndMinimise) {
  auto shape = make_shape(ShapeKind::Cactus, 32);
  engine::SwapchainTarget target(*context, [this] { return framebuffer_size(); }, 4, false);
  engine::FrameSlots slots(*context);
  engine::MeshRenderer renderer(*context, target.render_pass(), target.format(), slots.count());
  engine::GeometryExchange exchange(static_cast<std::size_t>(shape.mesh.vertex_count()));
  engine::GeometryPublisher(exchange, shape.mesh.triangles).publish(shape.mesh.positions);
  const auto bounds = engine::Bounds::of(shape.mesh.positions);
  renderer.set_mesh(shape.mesh.triangles, exchange, bounds, engine::UpAxis::Z);
  engine::RenderSettings settings;

  // Draws `frames` frames; the last one is kept for reading back. Returns false if no frame
  // could be drawn (minimised).
  auto draw = [&](int frames) {
    bool drew = false;
    for (int k = 0; k < frames; ++k) {
      glfwPollEvents();
      auto& slot = slots.begin();
      uint32_t image = 0;
      if (!target.acquire(slot.image_available, image)) continue;
      const VkExtent2D extent = target.extent();
      const auto camera = engine::Camera::three_quarter_front(bounds, engine::UpAxis::Z, float(extent.width) / float(extent.height));
      renderer.prepare(slot.index, camera, settings, extent);
      target.begin(slot.commands, image);
      renderer.record(slot.commands, slot.index, extent);
      target.end(slot.commands, image, k == frames - 1);
      slots.submit(slot, slot.image_available, target.render_finished(image));
      target.present(image);
      drew = true;
    }
    slots.wait_all();
    return drew;
  };

  ASSERT_TRUE(draw(6));
  const engine::Pixels window_image = target.read_last_image();
  ASSERT_EQ(window_image.width, target.extent().width);
  engine::Shot shot;
  shot.width = target.extent().width;
  shot.height = target.extent().height;
  engine::Scene scene;
  scene.positions = shape.mesh.positions;
  scene.triangles = shape.mesh.triangles;
  const engine::Pixels offscreen = engine::render_offscreen(*context, scene, shot);
  const auto difference = test::compare_images(window_image, offscreen, 24);
  EXPECT_LE(difference.differing_fraction, 0.005) << "largest difference " << difference.largest;

  glfwSetWindowSize(window, 400, 300);
  for (int k = 0; k < 20 && framebuffer_size().width != 400; ++k) glfwWaitEventsTimeout(0.05);
  ASSERT_TRUE(draw(4));
  EXPECT_EQ(target.extent().width, 400u);
  EXPECT_EQ(target.read_last_image().height, 300u);

  glfwIconifyWindow(window);
  for (int k = 0; k < 10; ++k) glfwWaitEventsTimeout(0.02);
  draw(3);  // whatever the window system does with a minimised window, nothing may break
  glfwRestoreWindow(window);
  for (int k = 0; k < 10; ++k) glfwWaitEventsTimeout(0.02);
  EXPECT_TRUE(draw(3));
}

}  // namespace
}  // namespace hdeform

#pragma once
// Helpers for rendering tests: a validated Vulkan context and image comparison with a
// tolerance. Golden images live in tests/golden; HDEFORM_UPDATE_GOLDEN=1 rewrites them from the
// current renderer (on purpose only: look at the new pictures before committing them).
#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <string>

#include "hdeform/engine/camera.h"
#include "hdeform/engine/frame_slots.h"
#include "hdeform/engine/mesh_renderer.h"
#include "hdeform/engine/offscreen.h"
#include "hdeform/engine/render_targets.h"
#include "hdeform/engine/vulkan_context.h"

namespace hdeform::test {

// A context with the Khronos validation layer on (messages counted). Rendering tests assert
// that the count stays zero.
std::unique_ptr<engine::VulkanContext> validated_context();

struct ImageDifference {
  double differing_fraction = 0.0;  // pixels whose largest channel difference exceeds the tolerance
  int largest = 0;                  // largest channel difference over all pixels
};
ImageDifference compare_images(const engine::Pixels& a, const engine::Pixels& b, int tolerance);

// Compares with tests/golden/<name>.png (or rewrites it when HDEFORM_UPDATE_GOLDEN=1); on a
// mismatch the rendered image is written next to the build for inspection.
void expect_matches_golden(const engine::Pixels& image, const std::string& name);

// One frame of `renderer` into `target`, waited for: its pixels.
engine::Pixels draw_frame(engine::MeshRenderer& renderer, engine::FrameSlots& slots, engine::OffscreenTarget& target, const engine::Camera& camera,
                          const engine::RenderSettings& settings);

// Pixel (x, y) as r, g, b in [0, 1].
Eigen::Vector3f pixel(const engine::Pixels& image, uint32_t x, uint32_t y);

}  // namespace hdeform::test

#include "render_support.h"

#include <gtest/gtest.h>

#include <cstdlib>

#include "hdeform/engine/image_io.h"

namespace hdeform::test {

engine::Pixels draw_frame(engine::MeshRenderer& renderer, engine::FrameSlots& slots, engine::OffscreenTarget& target, const engine::Camera& camera,
                          const engine::RenderSettings& settings) {
  auto& slot = slots.begin();
  renderer.prepare(slot.index, camera, settings, target.extent());
  target.begin(slot.commands);
  renderer.record(slot.commands, slot.index, target.extent());
  target.finish(slot.commands);
  slots.submit(slot);
  slots.wait_all();
  return target.pixels();
}

std::unique_ptr<engine::VulkanContext> validated_context() {
  engine::ContextOptions options;
  options.validation = true;
  options.announce = false;
  return std::make_unique<engine::VulkanContext>(options);
}

ImageDifference compare_images(const engine::Pixels& a, const engine::Pixels& b, int tolerance) {
  ImageDifference difference;
  if (a.width != b.width || a.height != b.height) {
    difference.differing_fraction = 1.0;
    difference.largest = 255;
    return difference;
  }
  std::size_t differing = 0;
  for (std::size_t p = 0; p < a.rgba.size(); p += 4) {
    int worst = 0;
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(a.rgba[p + c]) - int(b.rgba[p + c])));
    difference.largest = std::max(difference.largest, worst);
    if (worst > tolerance) ++differing;
  }
  difference.differing_fraction = static_cast<double>(differing) / static_cast<double>(a.rgba.size() / 4);
  return difference;
}

void expect_matches_golden(const engine::Pixels& image, const std::string& name) {
  const auto golden = std::filesystem::path(HDEFORM_SOURCE_DIR) / "tests" / "golden" / (name + ".png");
  const char* update = std::getenv("HDEFORM_UPDATE_GOLDEN");
  if (update != nullptr && std::string(update) == "1") {
    engine::write_png(golden, image);
    std::cout << "rewrote " << golden << '\n';
    return;
  }
  ASSERT_TRUE(std::filesystem::exists(golden)) << golden << " is missing (HDEFORM_UPDATE_GOLDEN=1 creates it)";
  const engine::Pixels reference = engine::read_png(golden);
  // Rasteriser noise moves single edge pixels by a few levels; a wrong colormap, camera, missing
  // mesh or swapped channel changes many pixels by a lot.
  const auto difference = compare_images(image, reference, 24);
  if (difference.differing_fraction > 0.005) {
    const auto actual = std::filesystem::path(name + "-actual.png");
    engine::write_png(actual, image);
    ADD_FAILURE() << name << ": " << 100.0 * difference.differing_fraction << "% of the pixels differ from " << golden
                  << " by more than 24 levels (largest " << difference.largest << "); this render is in "
                  << std::filesystem::absolute(actual);
  }
}

Eigen::Vector3f pixel(const engine::Pixels& image, uint32_t x, uint32_t y) {
  const std::size_t p = 4 * (std::size_t{y} * image.width + x);
  return Eigen::Vector3f(image.rgba[p], image.rgba[p + 1], image.rgba[p + 2]) / 255.0f;
}

}  // namespace hdeform::test

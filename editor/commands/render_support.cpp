#include "render_support.h"

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "cli_support.h"
#include "hdeform/engine/image_io.h"
#include "hdeform/engine/mesh_renderer.h"
#include "hdeform/stopwatch.h"

namespace hdeform::cli {
namespace {

// Comma-separated numbers; UsageError naming the option when malformed.
std::vector<double> parse_numbers(const std::string& text, const std::string& option) {
  std::vector<double> numbers;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    try {
      std::size_t used = 0;
      numbers.push_back(std::stod(item, &used));
      if (used != item.size() || !std::isfinite(numbers.back())) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw UsageError(option + ": '" + item + "' is not a number");
    }
  }
  return numbers;
}

}  // namespace

void PictureOptions::add_options(CLI::App& command) {
  command.add_option("--size", size, "Image size WIDTHxHEIGHT")->capture_default_str();
  command.add_option("--camera", camera, "View: YAW,PITCH[,ZOOM] in degrees about the up axis (default: three-quarter front)");
  command.add_option("--up", up, "Up axis of the mesh: z or y")->capture_default_str();
  command.add_option("--range", range, "Field values at the colormap's ends: LO,HI (default 0,1)");
  command.add_option("--isolines", isolines, "Isoline step in field units (0: none)")->capture_default_str();
  command.add_option("--samples", samples, "Multisampling (reduced to what the device supports)")->capture_default_str();
  command.add_flag("--wireframe", wireframe, "Draw the triangle edges");
  command.add_flag("--flat", flat, "Flat shading");
  command.add_flag("--no-ground", no_ground, "No ground grid");
  command.add_flag("--no-lighting", no_lighting, "Plain colours, no shading");
  command.add_flag("--no-legend", no_legend, "No colour bar");
  command.add_option("--device", device, "Vulkan device: gpu, cpu, an index or part of a name (default: $HDEFORM_VULKAN_DEVICE, else the best)");
  command.add_flag("--validation", validation, "Enable the Khronos validation layer");
}

engine::UpAxis PictureOptions::up_axis() const {
  if (up == "z") return engine::UpAxis::Z;
  if (up == "y") return engine::UpAxis::Y;
  throw UsageError("--up must be z or y");
}

engine::Shot PictureOptions::shot(const engine::Bounds& bounds, uint32_t panels) const {
  engine::Shot shot;
  auto [width, height] = parse_size(size, "--size", 1, 1, 16384);
  if (panels > 1 && width / panels == 0) throw UsageError("--size is too narrow for " + std::to_string(panels) + " panels");
  width /= std::max(panels, 1u);
  shot.width = width;
  shot.height = height;
  if (samples < 1) throw UsageError("--samples must be at least 1");
  shot.samples = samples;
  shot.settings.wireframe = wireframe;
  shot.settings.flat_shading = flat;
  shot.settings.ground = !no_ground;
  shot.settings.lighting = !no_lighting;
  shot.settings.legend = !no_legend;
  if (isolines < 0.0) throw UsageError("--isolines must not be negative");
  shot.settings.isoline_step = static_cast<float>(isolines);
  if (!range.empty()) {
    const auto values = parse_numbers(range, "--range");
    if (values.size() != 2 || !(values[0] < values[1])) throw UsageError("--range must be LO,HI with LO < HI");
    shot.settings.field_min = static_cast<float>(values[0]);
    shot.settings.field_max = static_cast<float>(values[1]);
  }
  if (!camera.empty()) {
    const auto values = parse_numbers(camera, "--camera");
    if (values.size() < 2 || values.size() > 3 || (values.size() == 3 && !(values[2] > 0.0))) {
      throw UsageError("--camera must be YAW,PITCH[,ZOOM] (degrees; zoom > 0)");
    }
    auto view = engine::Camera::three_quarter_front(bounds, up_axis(), static_cast<float>(width) / static_cast<float>(height));
    view.yaw = static_cast<float>(values[0] * std::numbers::pi / 180.0);
    view.pitch = static_cast<float>(values[1] * std::numbers::pi / 180.0);
    if (values.size() == 3) view.distance *= static_cast<float>(values[2]);
    shot.camera = view;
  }
  return shot;
}

engine::ContextOptions PictureOptions::context() const {
  engine::ContextOptions options;
  options.device = device;
  options.validation = validation;
  options.announce = !quiet;
  return options;
}

std::vector<uint32_t> vertex_classes(const VertexPartition& partition) {
  std::vector<uint32_t> classes(partition.role.size(), HD_CLASS_FREE);
  for (std::size_t v = 0; v < classes.size(); ++v) {
    if (partition.role[v] == VertexRole::Fixed) classes[v] = engine::fixed_class();
    if (partition.role[v] == VertexRole::Handle) classes[v] = engine::handle_class(static_cast<std::size_t>(partition.handle_index[v]));
  }
  return classes;
}

nlohmann::json render_png(const PictureOptions& options, const engine::Scene& scene, const std::string& path) {
  return render_png(options, std::span(&scene, 1), path);
}

nlohmann::json render_png(const PictureOptions& options, std::span<const engine::Scene> panels, const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  const engine::VulkanContext context(options.context());
  const auto count = static_cast<uint32_t>(panels.size());
  engine::Pixels picture;
  for (uint32_t p = 0; p < count; ++p) {
    const engine::Scene& scene = panels[p];
    const engine::Bounds bounds = scene.rest_bounds.radius() > 0.0f ? scene.rest_bounds : engine::Bounds::of(scene.positions);
    const engine::Pixels pixels = engine::render_offscreen(context, scene, options.shot(bounds, count));
    if (p == 0) {
      picture.width = pixels.width * count;
      picture.height = pixels.height;
      picture.rgba.assign(std::size_t{4} * picture.width * picture.height, 0);
    }
    for (uint32_t y = 0; y < pixels.height; ++y) {
      std::copy_n(pixels.rgba.begin() + std::ptrdiff_t{4} * y * pixels.width, std::size_t{4} * pixels.width,
                  picture.rgba.begin() + std::ptrdiff_t{4} * (std::size_t{y} * picture.width + std::size_t{p} * pixels.width));
    }
  }
  engine::write_png(path, picture);
  return {{"png", path},
          {"device", context.device_name()},
          {"width", picture.width},
          {"height", picture.height},
          {"validation_messages", context.validation_message_count()},
          {"render_ms", milliseconds_since(start)}};
}

}  // namespace hdeform::cli

#pragma once
// Picture options shared by `hdeform render` and the --png options of edit and field.
#include "cli_fwd.h"
#include <nlohmann/json_fwd.hpp>

#include <optional>
#include <span>
#include <string>

#include "hdeform/constraints.h"
#include "hdeform/engine/offscreen.h"
#include "hdeform/engine/vulkan_context.h"

namespace hdeform::cli {

struct PictureOptions {
  std::string size = "1024x768";
  std::string camera;  // "YAW,PITCH[,ZOOM]" in degrees; zoom multiplies the fitted distance
  std::string up = "z";
  std::string range;   // "LO,HI": the field values at the colormap's ends
  double isolines = 0.1;
  int samples = 4;
  bool wireframe = false;
  bool flat = false;
  bool no_ground = false;
  bool no_lighting = false;
  bool no_legend = false;
  std::string device;
  bool validation = false;
  bool quiet = false;  // the command's --quiet: the chosen device is not announced either

  void add_options(CLI::App& command);
  engine::UpAxis up_axis() const;
  // Throws UsageError for a malformed size, camera or range. With `panels`, the shot is one of
  // that many side by side (its width the size's divided by them).
  engine::Shot shot(const engine::Bounds& bounds, uint32_t panels = 1) const;
  engine::ContextOptions context() const;
};

// Per-vertex classes for the renderer from a partition (fixed, handle k, free).
std::vector<uint32_t> vertex_classes(const VertexPartition& partition);

// Renders `scene` to a PNG at `path`; returns figures for the JSON report (device, size, ms).
nlohmann::json render_png(const PictureOptions& options, const engine::Scene& scene, const std::string& path);
// Several scenes side by side, each framed on its own, sharing the --size width.
nlohmann::json render_png(const PictureOptions& options, std::span<const engine::Scene> panels, const std::string& path);

}  // namespace hdeform::cli

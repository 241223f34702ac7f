#pragma once
/// @file
/// One picture of a mesh, without a window: what `hdeform render`, `edit --png` and the golden-
/// image tests use.
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "hdeform/engine/camera.h"
#include "hdeform/engine/mesh_renderer.h"
#include "hdeform/engine/render_targets.h"
#include "hdeform/engine/vulkan_context.h"

namespace hdeform::engine {

/// What an offscreen picture shows: a mesh and what is drawn on it.
struct Scene {
  Eigen::MatrixXd positions;       ///< n×3, as drawn
  Eigen::MatrixXi triangles;       ///< m×3
  Eigen::VectorXd field;           ///< per vertex, or empty
  std::vector<uint32_t> classes;   ///< per vertex (fixed_class(), handle_class(k)), or empty
  std::vector<Marker> markers;
  Bounds rest_bounds;              ///< places the camera and the ground; from positions when empty
  UpAxis up = UpAxis::Z;
  Eigen::MatrixXi proxy_triangles; ///< drawn instead with shot.settings.proxy (proxy_mesh.h), or empty
};

/// How an offscreen picture is taken: its size, sampling, settings and camera.
struct Shot {
  uint32_t width = 512;
  uint32_t height = 512;
  int samples = 4;                 ///< reduced to what the device supports
  RenderSettings settings;
  std::optional<Camera> camera;    ///< default: three-quarter front view of rest_bounds
};

/// Renders a scene to pixels, waiting for the device.
Pixels render_offscreen(const VulkanContext& context, const Scene& scene, const Shot& shot);

}  // namespace hdeform::engine

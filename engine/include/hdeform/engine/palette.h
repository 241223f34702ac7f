#pragma once
/// @file
/// The colours the renderer uses: the scalar-field colormap (viridis, sampled at
/// HD_COLORMAP_SAMPLES points) and one colour per vertex class. The GPU gets these tables through
/// the frame uniforms; the C++ side evaluates the colormap the same way (for tests and legends).
#include <Eigen/Core>
#include <array>

#include "render_config.h"

namespace hdeform::engine {

/// The field's colormap (viridis) as the shaders sample it, from 0 to 1.
const std::array<Eigen::Vector3f, HD_COLORMAP_SAMPLES>& colormap_samples();

/// The colormap at t ∈ [0, 1] (clamped), interpolated like the shader does.
Eigen::Vector3f colormap(float t);

/// Fixed vertices, vertices outside the region of interest, then handle 0, 1, ...
const std::array<Eigen::Vector3f, HD_CLASS_COLORS>& class_colors();

}  // namespace hdeform::engine

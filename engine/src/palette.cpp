#include "hdeform/engine/palette.h"

#include <algorithm>
#include <cmath>

namespace hdeform::engine {

const std::array<Eigen::Vector3f, HD_COLORMAP_SAMPLES>& colormap_samples() {
  // viridis (van der Walt and Smith, CC0), sampled at 33 evenly spaced points.
  static const std::array<Eigen::Vector3f, HD_COLORMAP_SAMPLES> samples{{
      {0.2670f, 0.0049f, 0.3294f}, {0.2770f, 0.0503f, 0.3757f}, {0.2823f, 0.0950f, 0.4173f}, {0.2829f, 0.1359f, 0.4534f},
      {0.2788f, 0.1755f, 0.4834f}, {0.2706f, 0.2141f, 0.5071f}, {0.2590f, 0.2515f, 0.5247f}, {0.2450f, 0.2877f, 0.5373f},
      {0.2297f, 0.3224f, 0.5457f}, {0.2143f, 0.3556f, 0.5512f}, {0.1994f, 0.3876f, 0.5546f}, {0.1856f, 0.4186f, 0.5568f},
      {0.1727f, 0.4488f, 0.5579f}, {0.1607f, 0.4785f, 0.5581f}, {0.1490f, 0.5081f, 0.5573f}, {0.1378f, 0.5375f, 0.5549f},
      {0.1276f, 0.5669f, 0.5506f}, {0.1206f, 0.5964f, 0.5436f}, {0.1206f, 0.6258f, 0.5335f}, {0.1323f, 0.6550f, 0.5197f},
      {0.1579f, 0.6838f, 0.5017f}, {0.1966f, 0.7118f, 0.4792f}, {0.2461f, 0.7389f, 0.4520f}, {0.3041f, 0.7647f, 0.4199f},
      {0.3692f, 0.7889f, 0.3829f}, {0.4401f, 0.8111f, 0.3410f}, {0.5160f, 0.8312f, 0.2943f}, {0.5958f, 0.8487f, 0.2433f},
      {0.6785f, 0.8637f, 0.1895f}, {0.7624f, 0.8764f, 0.1371f}, {0.8456f, 0.8873f, 0.0997f}, {0.9261f, 0.8973f, 0.1041f},
      {0.9932f, 0.9062f, 0.1439f},
  }};
  return samples;
}

Eigen::Vector3f colormap(float t) {
  const auto& samples = colormap_samples();
  const float position = std::clamp(t, 0.0f, 1.0f) * static_cast<float>(HD_COLORMAP_SAMPLES - 1);
  const int index = std::min(static_cast<int>(std::floor(position)), HD_COLORMAP_SAMPLES - 2);
  const float fraction = position - static_cast<float>(index);
  return (1.0f - fraction) * samples[static_cast<std::size_t>(index)] + fraction * samples[static_cast<std::size_t>(index) + 1];
}

const std::array<Eigen::Vector3f, HD_CLASS_COLORS>& class_colors() {
  // Fixed: blue (the paper's sinks); outside the region of interest: grey; handles: red first
  // (the paper's source), then distinct hues.
  static const std::array<Eigen::Vector3f, HD_CLASS_COLORS> colors{{
      {0.15f, 0.35f, 0.95f},  // fixed
      {0.45f, 0.46f, 0.50f},  // outside the region of interest
      {0.92f, 0.16f, 0.12f},  // handle 1
      {0.98f, 0.62f, 0.05f},  // handle 2
      {0.10f, 0.75f, 0.35f},  // handle 3
      {0.75f, 0.20f, 0.85f},  // handle 4
      {0.05f, 0.80f, 0.85f},  // handle 5
      {0.95f, 0.40f, 0.65f},  // handle 6
      {0.60f, 0.45f, 0.20f},  // handle 7
      {0.55f, 0.55f, 0.55f},  // handle 8
  }};
  return colors;
}

}  // namespace hdeform::engine

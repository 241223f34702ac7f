#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"
layout(location = 0) in float height;
layout(location = 0) out vec4 color;
void main() {
  // Vulkan's clip y points down: height 0 is the top of the screen.
  color = vec4(mix(frame.background_top.rgb, frame.background_bottom.rgb, clamp(height * 0.5, 0.0, 1.0)), 1.0);
}

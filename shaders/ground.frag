#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"
layout(location = 0) in vec2 plane;
layout(location = 0) out vec4 color;
void main() {
  vec2 cell = plane / frame.ground_origin.w;
  vec2 distance_px = abs(fract(cell + 0.5) - 0.5) / max(fwidth(cell), vec2(1e-12));
  float line = 1.0 - clamp(min(distance_px.x, distance_px.y) - 0.5, 0.0, 1.0);
  float fade = 1.0 - smoothstep(0.35 * frame.ground_v.w, frame.ground_v.w, length(plane));
  color = vec4(vec3(0.30, 0.32, 0.36), fade * (0.12 + 0.38 * line));
}

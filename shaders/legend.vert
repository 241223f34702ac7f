#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"
layout(location = 0) out vec2 uv;
void main() {
  // The colour bar at the right edge: 18 px wide, 40% of the height, with a 2 px frame.
  const vec2 corners[6] = vec2[](vec2(0, 0), vec2(1, 0), vec2(1, 1), vec2(0, 0), vec2(1, 1), vec2(0, 1));
  vec2 corner = corners[gl_VertexIndex];
  vec2 size_px = vec2(22.0, 0.4 * frame.viewport.y + 4.0);
  vec2 origin_px = vec2(frame.viewport.x - 24.0 - size_px.x, 0.7 * frame.viewport.y + 2.0);  // bottom-left, y down
  vec2 pixel = origin_px + vec2(corner.x, -corner.y) * size_px;
  uv = (corner * size_px - 2.0) / (size_px - 4.0);  // 0..1 inside the frame
  gl_Position = vec4(pixel / frame.viewport.xy * 2.0 - 1.0, 0.0, 1.0);
}

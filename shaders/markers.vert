#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"
layout(location = 0) in vec3 marker_position;
layout(location = 1) in uint marker_color;
layout(location = 0) out vec2 offset;
layout(location = 1) out vec3 color;
void main() {
  const vec2 corners[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
  offset = corners[gl_VertexIndex];
  color = frame.class_colors[HD_FIRST_HANDLE_COLOR + marker_color % uint(HD_HANDLE_COLORS)].rgb;
  vec4 clip = frame.view_projection * vec4(marker_position, 1.0);
  clip.xy += offset * HD_MARKER_PIXELS / frame.viewport.xy * clip.w;
  clip.z -= 1e-3 * clip.w;  // in front of the surface it sits on
  gl_Position = clip;
}

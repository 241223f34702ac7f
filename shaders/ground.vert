#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"
layout(location = 0) out vec2 plane;  // coordinates in the ground plane, relative to its centre
void main() {
  // Two triangles spanning the ground square under the mesh.
  const vec2 corners[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
  plane = corners[gl_VertexIndex] * frame.ground_u.w;
  vec3 world = frame.ground_origin.xyz + plane.x * frame.ground_u.xyz + plane.y * frame.ground_v.xyz;
  gl_Position = frame.view_projection * vec4(world, 1.0);
}

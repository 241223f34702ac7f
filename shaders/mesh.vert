#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"

// Few interpolated values: a CPU rasterizer sets up every one of them for every triangle, and
// they dominate its cost on large meshes. The class colour is looked up from a flat class
// index (each triangle's first vertex is a constrained one where it has any); the lighting uses
// the view direction, so positions are interpolated only for flat shading.
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in float field_value;
layout(location = 3) in uint vertex_class;

layout(location = 0) out vec3 world_normal;
layout(location = 1) out float field;
layout(location = 2) out float class_weight;  // 1 at constrained vertices, 0 at free ones
layout(location = 3) flat out uint triangle_class;
#ifdef HD_VARIANT_FLAT
layout(location = 4) out vec3 world_position;
#endif

void main() {
  world_normal = normal;
  field = field_value;
  class_weight = vertex_class == HD_CLASS_FREE ? 0.0 : 1.0;
  triangle_class = vertex_class;
#ifdef HD_VARIANT_FLAT
  world_position = position;
#endif
  gl_Position = frame.view_projection * vec4(position, 1.0);
}

#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"

// On a CPU rasterizer a dense mesh's triangles cover a pixel or two while the fragment shader
// runs on whole blocks of pixels, so the fragment work per triangle is many times the visible
// pixels. Smooth shading therefore lights per vertex (on dense meshes indistinguishable from per
// pixel, and measured cheaper); the flat variant needs positions and lights per pixel.
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in float field_value;
layout(location = 3) in uint vertex_class;

layout(location = 0) out float field;
layout(location = 1) out vec4 class_color;  // rgb; a: 1 at constrained vertices, 0 at free ones
#ifdef HD_VARIANT_FLAT
layout(location = 2) out vec3 world_position;
#else
layout(location = 2) out vec2 light;
#endif

void main() {
  field = field_value;
  if ((vertex_class & HD_CLASS_RGB) != 0u) {
    class_color = vec4(unpackUnorm4x8(vertex_class).rgb, 1.0);
  } else if (vertex_class == HD_CLASS_FREE) {
    class_color = vec4(0.0);
  } else if (vertex_class == HD_CLASS_FIXED) {
    class_color = vec4(frame.class_colors[0].rgb, 1.0);
  } else if (vertex_class == HD_CLASS_OUTSIDE) {
    class_color = vec4(frame.class_colors[1].rgb, 1.0);
  } else {
    uint handle = (vertex_class - HD_CLASS_HANDLE_FIRST) % uint(HD_HANDLE_COLORS);
    class_color = vec4(frame.class_colors[HD_FIRST_HANDLE_COLOR + handle].rgb, 1.0);
  }
#ifdef HD_VARIANT_FLAT
  world_position = position;
#else
  light = light_terms(normalize(normal));
#endif
  gl_Position = frame.view_projection * vec4(position, 1.0);
}

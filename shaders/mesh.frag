#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"

layout(location = 0) in vec3 world_normal;
layout(location = 1) in float field;
layout(location = 2) in float class_weight;
layout(location = 3) flat in uint triangle_class;
#ifdef HD_VARIANT_FLAT
layout(location = 4) in vec3 world_position;
#endif
layout(location = 0) out vec4 color;

vec3 class_color(uint vertex_class) {
  if (vertex_class == HD_CLASS_FIXED) return frame.class_colors[0].rgb;
  return frame.class_colors[1u + (vertex_class - HD_CLASS_HANDLE_FIRST) % uint(HD_HANDLE_COLORS)].rgb;
}

void main() {
  uint flags = frame.flags.x;
  vec3 albedo = frame.base_color.rgb;
  if ((flags & HD_SHOW_FIELD) != 0u) {
    albedo = field_color(field);
    // Isolines at every multiple of the step, anti-aliased, about `width` pixels wide.
    float step_value = frame.field_range.z;
    if (step_value > 0.0) {
      float scaled = (field - frame.field_range.x) / step_value;
      float distance_px = abs(fract(scaled + 0.5) - 0.5) / max(fwidth(scaled), 1e-12);
      float line = 1.0 - smoothstep(0.5 * frame.field_range.w - 0.5, 0.5 * frame.field_range.w + 0.5, distance_px);
      albedo = mix(albedo, vec3(0.08), 0.85 * line);
    }
  }
  if ((flags & HD_SHOW_CLASSES) != 0u && triangle_class != HD_CLASS_FREE) {
    albedo = mix(albedo, class_color(triangle_class), clamp(class_weight * 1.5, 0.0, 1.0));
  }
  if (!gl_FrontFacing) albedo = mix(albedo, frame.back_color.rgb, frame.back_color.a);

#ifdef HD_VARIANT_FLAT
  vec3 n = normalize(cross(dFdx(world_position), dFdy(world_position)));
#else
  vec3 n = normalize(world_normal);
#endif
  vec3 to_eye = frame.camera_position.xyz;  // the direction towards the viewer (see FrameUniforms)
  if (dot(n, to_eye) < 0.0) n = -n;  // light both sides
  vec3 shaded = albedo;
  if ((flags & HD_LIGHTING) != 0u) {
    vec3 l = frame.light_direction.xyz;
    float diffuse = max(dot(n, l), 0.0);
    float fill = max(dot(n, to_eye), 0.0);
    float specular = pow(max(dot(n, normalize(l + to_eye)), 0.0), 48.0);
    shaded = albedo * (0.22 + 0.55 * diffuse + 0.30 * fill) + vec3(0.18 * specular);
  }
  color = vec4(shaded, 1.0);
}

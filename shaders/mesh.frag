#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"

layout(location = 0) in float field;
layout(location = 1) in vec4 class_color;
#ifdef HD_VARIANT_FLAT
layout(location = 2) in vec3 world_position;
#else
layout(location = 2) in vec2 light;
#endif
layout(location = 0) out vec4 color;

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
  if ((flags & HD_SHOW_CLASSES) != 0u && class_color.a > 0.0) {
    albedo = mix(albedo, class_color.rgb / class_color.a, clamp(class_color.a, 0.0, 1.0));
  }
  if (!gl_FrontFacing) albedo = mix(albedo, frame.back_color.rgb, frame.back_color.a);
#ifdef HD_VARIANT_FLAT
  vec2 light = light_terms(normalize(cross(dFdx(world_position), dFdy(world_position))));
#endif
  color = vec4(albedo * light.x + light.y, 1.0);
}

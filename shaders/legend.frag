#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() {
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) {
    color = vec4(0.1, 0.1, 0.12, 1.0);  // frame
    return;
  }
  float value = mix(frame.field_range.x, frame.field_range.y, uv.y);
  vec3 c = field_color(value);
  float step_value = frame.field_range.z;
  if (step_value > 0.0) {
    float scaled = (value - frame.field_range.x) / step_value;
    float distance_px = abs(fract(scaled + 0.5) - 0.5) / max(fwidth(scaled), 1e-12);
    if (uv.x > 0.55 && distance_px < 0.75) c = vec3(0.08);  // tick at each isoline value
  }
  color = vec4(c, 1.0);
}

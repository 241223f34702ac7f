#version 450
layout(location = 0) in vec2 offset;
layout(location = 1) in vec3 color;
layout(location = 0) out vec4 out_color;
void main() {
  float r = length(offset);
  if (r > 1.0) discard;
  out_color = vec4(r > 0.7 ? vec3(0.05) : color, 1.0);
}

#version 450
layout(location = 0) out vec4 color;
void main() { color = vec4(0.05, 0.05, 0.07, 1.0); }

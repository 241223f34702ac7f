#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_config.h"
#include "frame_uniforms.glsl"
layout(location = 0) in vec3 position;
void main() { gl_Position = frame.view_projection * vec4(position, 1.0); }

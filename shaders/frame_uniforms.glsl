// The per-frame uniform block; mirrored by FrameUniforms in engine/src/mesh_renderer.cpp (std140).
layout(set = 0, binding = HD_BINDING_FRAME_UNIFORMS, std140) uniform FrameUniforms {
  mat4 view_projection;
  vec4 camera_position;    // xyz: unit direction towards the viewer (lighting treats the view as directional)
  vec4 light_direction;    // xyz: unit direction towards the light
  vec4 field_range;        // x: value at the colormap's start, y: at its end, z: isoline step, w: isoline width (px)
  uvec4 flags;             // x: HD_* bits
  vec4 base_color;         // surface colour without field
  vec4 back_color;         // tint of back faces
  vec4 ground_origin;      // xyz: centre of the ground square, w: grid spacing
  vec4 ground_u;           // xyz: unit axis in the ground plane, w: half extent
  vec4 ground_v;           // xyz: the other axis, w: radius where the grid has faded out
  vec4 viewport;           // x, y: size in pixels
  vec4 class_colors[HD_CLASS_COLORS];
  vec4 colormap[HD_COLORMAP_SAMPLES];
} frame;

vec3 field_color(float value) {
  float t = clamp((value - frame.field_range.x) / max(frame.field_range.y - frame.field_range.x, 1e-30), 0.0, 1.0);
  float position = t * float(HD_COLORMAP_SAMPLES - 1);
  int index = min(int(floor(position)), HD_COLORMAP_SAMPLES - 2);
  return mix(frame.colormap[index].rgb, frame.colormap[index + 1].rgb, position - float(index));
}

// Lighting of a surface with unit normal n (either side): x multiplies the albedo, y adds a
// white highlight. A headlight-style fill plus a key light above and to the left.
vec2 light_terms(vec3 n) {
  if ((frame.flags.x & HD_LIGHTING) == 0u) return vec2(1.0, 0.0);
  vec3 to_eye = frame.camera_position.xyz;
  if (dot(n, to_eye) < 0.0) n = -n;
  vec3 l = frame.light_direction.xyz;
  float diffuse = max(dot(n, l), 0.0);
  float fill = max(dot(n, to_eye), 0.0);
  float specular = pow(max(dot(n, normalize(l + to_eye)), 0.0), 48.0);
  return vec2(0.22 + 0.55 * diffuse + 0.30 * fill, 0.18 * specular);
}

// Constants shared by the C++ engine and the GLSL shaders (included by both; #defines only).
#ifndef HDEFORM_RENDER_CONFIG_H
#define HDEFORM_RENDER_CONFIG_H

// Vertex classes as stored in the per-vertex class attribute.
#define HD_CLASS_FREE 0u
#define HD_CLASS_FIXED 1u
#define HD_CLASS_OUTSIDE 2u       // outside the region of interest (held in place, shown dimmed)
#define HD_CLASS_HANDLE_FIRST 3u  // handle k is HD_CLASS_HANDLE_FIRST + k
#define HD_CLASS_RGB 0x80000000u  // with this bit, the class carries its own colour: 0x80BBGGRR

// Colours per class: fixed, outside, then one per handle (cycled beyond this many).
#define HD_HANDLE_COLORS 8
#define HD_FIRST_HANDLE_COLOR 2
#define HD_CLASS_COLORS (2 + HD_HANDLE_COLORS)

// Samples of the scalar-field colormap, spread evenly over [0, 1], linearly interpolated.
#define HD_COLORMAP_SAMPLES 33

// Bits of FrameUniforms.flags.x
#define HD_SHOW_FIELD 1u
#define HD_SHOW_CLASSES 2u
#define HD_FLAT_SHADING 4u
#define HD_LIGHTING 8u
#define HD_SHOW_GROUND 16u
#define HD_SHOW_LEGEND 32u

// Descriptor set 0.
#define HD_BINDING_FRAME_UNIFORMS 0

// Vertex input bindings.
#define HD_VERTEX_BINDING_GEOMETRY 0   // position xyz, normal xyz (floats)
#define HD_VERTEX_BINDING_ATTRIBUTES 1 // field value (float), class (uint)
#define HD_VERTEX_BINDING_MARKERS 2    // per instance: position xyz, colour index

// Marker size on screen, pixels.
#define HD_MARKER_PIXELS 9.0

#endif

#pragma once
/// @file
/// Procedural meshes, deterministic at any resolution, each with a demonstration edit. They make
/// the demo and most tests independent of files. All are closed, edge-manifold, one component,
/// with outward counter-clockwise triangles; z is up.
#include <optional>
#include <string_view>

#include "hdeform/constraints.h"
#include "hdeform/handle_transform.h"
#include "hdeform/mesh.h"

namespace hdeform {

/// The built-in shapes.
enum class ShapeKind {
  Cactus,    ///< a trunk with two arms; demo: the paper's Figure 1 (bend the left arm)
  Bar,       ///< a square bar; demo: twist the top end
  Cylinder,  ///< a capped cylinder; demo: bend the top
  Sphere,    ///< a sphere from a subdivided cube; demo: pull the top cap
};

/// The shape named `name` ("cactus", "bar", "cylinder", "sphere"), or nullopt.
std::optional<ShapeKind> parse_shape(std::string_view name);
/// The shape's name.
std::string_view to_string(ShapeKind shape);

/// The demo edit: one source and one sink region and the handle's transform.
struct Shape {
  Mesh mesh;
  EditConstraints demo_constraints;
  HandleTransform demo_transform;
};

/// `resolution` ≥ 8 is the number of segments around the shape; the
/// triangle count grows with its square (cactus about 5.1 r², cylinder 2.9 r², bar 3.4 r², sphere
/// 0.75 r²: r = 450, 600, 560, 1160 give a million triangles or more).
Shape make_shape(ShapeKind shape, int resolution);

/// Segments around, when a caller does not say.
inline constexpr int kDefaultShapeResolution = 48;

}  // namespace hdeform

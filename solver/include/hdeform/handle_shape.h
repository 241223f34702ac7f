#pragma once
/// @file
/// How a handle sits on the surface. A handle that wraps only part of the way round a limb (half a
/// ring, as a brush that paints only the side facing the camera leaves it) has a lopsided
/// harmonic field: 1 on the painted side, falling off round the other, so the cross-section under
/// the handle shears and a bend or twist leans it instead of turning it. Found from the unit
/// normals of the handle's vertices: they lie near one plane (the cross-section's) and turn
/// through more than a quarter but clearly less than a whole turn about its normal. Caps, patches
/// and full rings are not flagged.
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/mesh.h"

namespace hdeform {

/// The degrees a partial ring's normals turn through (90 to 300), or nothing for any other
/// handle. O(size of the handle + triangles).
std::optional<double> partial_ring_degrees(const Mesh& mesh, std::span<const int> handle);

/// One line per handle that is a partial ring, naming it and the degrees, and what to do.
std::vector<std::string> handle_shape_warnings(const Mesh& mesh, const EditConstraints& constraints);

}  // namespace hdeform

#pragma once
// The mesh readers of our own, for the formats whose OpenMesh readers cannot be trusted with
// hostile files: each trusted a size its file gave and read that many values whatever the file
// held (a 100-byte OFF file and a 231-byte PLY file made it allocate 2 GB). Here every size is
// checked against the bytes that are left before anything is reserved. Each throws InputError
// "<file>:<line>: <problem>" (a binary body names the byte instead).
#include <filesystem>
#include <string_view>

#include "hdeform/mesh.h"

namespace hdeform::detail {

// An ASCII OFF file (OFF, COFF, NOFF, CNOFF, STOFF... headers). One vertex per line (x y z, then
// colours or normals, ignored), one face per line (its size, that many indices, then a colour,
// ignored); '#' comments anywhere. Coordinates in double precision.
Mesh parse_off(const std::filesystem::path& path, std::string_view content);

// A PLY file, ASCII or binary in either byte order. The header must declare a "vertex" element
// with scalar x, y and z and a "face" element with a vertex_indices (or vertex_index) list of an
// integer type; every other element and property is read past and ignored. Lists may have any
// integer length type. A coordinate keeps its declared precision: a float property gives the
// float, a double the double. The ASCII body is read as whitespace-separated values, as the
// header lists them, whatever the line breaks.
Mesh parse_ply(const std::filesystem::path& path, std::string_view content);

}  // namespace hdeform::detail

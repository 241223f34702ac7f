#pragma once
// What OpenMesh's readers cannot be trusted with. The PLY header is checked strictly before
// OpenMesh reads the body, since OpenMesh trusts it: a count that does not parse or is larger
// than the file could hold made it allocate until memory ran out (minutes, then
// std::bad_alloc), and a misspelt magic read garbage as a mesh. Each check throws InputError
// "<file>:<line>: <problem>".
#include <filesystem>
#include <string>
#include <string_view>

#include "hdeform/mesh.h"

namespace hdeform::detail {

// A PLY header: "ply", a known format, elements with counts and typed properties, "end_header";
// a "vertex" element with x, y and z and a "face" element with a vertex_indices (or
// vertex_index) list; counts that fit in the bytes after the header.
void check_ply_header(const std::filesystem::path& path, std::string_view content);

// An ASCII OFF file (OFF, COFF, NOFF, CNOFF, STOFF... headers), read here rather than by OpenMesh,
// whose reader takes a face's size from its token stream and reads that many indices whatever
// the file holds (a 100-byte file made it allocate 2 GB). One vertex per line (x y z, then
// colours or normals, ignored), one face per line (its size, that many indices, then a colour,
// ignored); '#' comments anywhere. Coordinates in double precision. Throws InputError
// "<file>:<line>: <problem>".
Mesh parse_off(const std::filesystem::path& path, std::string_view content);

}  // namespace hdeform::detail

#pragma once
#include <filesystem>
#include <string_view>

#include "hdeform/mesh.h"

namespace hdeform {

// Reads a Wavefront OBJ: vertices ("v x y z", up to four more numbers ignored) and faces ("f"
// with 1-based indices, negative ones relative to the vertices so far, "v/vt/vn" forms);
// everything else (normals, texture coordinates, groups, materials) is ignored and vertex order
// is kept (unreferenced vertices included). Quads are split along their shorter diagonal, larger
// polygons into a fan from their first corner.
// Lines end at LF, CRLF or a lone CR; a UTF-8 byte-order mark is skipped; '#' starts a comment; a
// backslash at the end of a line continues it on the next. Throws InputError
// "<file>:<line>: <problem>" for an unreadable or binary file, a malformed or non-finite
// coordinate, a face index that is zero or out of range, a face with fewer than three vertices,
// or a file with no faces. The mesh returned has passed validate_mesh.
Mesh read_obj(const std::filesystem::path& path);
// The same for OBJ text already in memory; `path` only names it in messages.
Mesh parse_obj(const std::filesystem::path& path, std::string_view content);

// Writes vertices (shortest round-trip decimal form) and triangles, atomically.
void write_obj(const std::filesystem::path& path, const Mesh& mesh);

}  // namespace hdeform

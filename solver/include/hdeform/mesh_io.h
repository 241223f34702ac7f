#pragma once
#include <filesystem>

#include "hdeform/mesh.h"

namespace hdeform {

// Reads a Wavefront OBJ through tinyobjloader: polygons are triangulated; normals, texture
// coordinates, groups and materials are ignored; vertex order is kept (unreferenced vertices
// included). Throws InputError "<file>:<line>: <problem>" for an unreadable or binary file, a
// malformed or non-finite coordinate, a face index that is zero or out of range, a face with
// fewer than three vertices, or a file with no triangles.
Mesh read_obj(const std::filesystem::path& path);

// Writes vertices (shortest round-trip decimal form) and triangles, atomically.
void write_obj(const std::filesystem::path& path, const Mesh& mesh);

}  // namespace hdeform

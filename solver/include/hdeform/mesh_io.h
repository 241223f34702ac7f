#pragma once
#include <filesystem>
#include <optional>
#include <string_view>

#include "hdeform/mesh.h"

namespace hdeform {

/// Reads a Wavefront OBJ: vertices ("v x y z", up to four more numbers ignored) and faces ("f"
/// with 1-based indices, negative ones relative to the vertices so far, "v/vt/vn" forms);
/// everything else (normals, texture coordinates, groups, materials) is ignored and vertex order
/// is kept (unreferenced vertices included). Quads are split along their shorter diagonal, larger
/// polygons into a fan from their first corner.
/// Lines end at LF, CRLF or a lone CR; a UTF-8 byte-order mark is skipped; '#' starts a comment; a
/// backslash at the end of a line continues it on the next. Throws InputError
/// "<file>:<line>: <problem>" for an unreadable or binary file, a malformed or non-finite
/// coordinate, a face index that is zero or out of range, a face with fewer than three vertices,
/// or a file with no faces. The mesh returned has passed validate_mesh.
Mesh read_obj(const std::filesystem::path& path);
/// The same for OBJ text already in memory; `path` only names it in messages.
Mesh parse_obj(const std::filesystem::path& path, std::string_view content);

/// Writes vertices (shortest round-trip decimal form) and triangles, atomically.
void write_obj(const std::filesystem::path& path, const Mesh& mesh);

/// The formats scans come in, chosen by the file's extension (any case).
///   .obj  the reader above;
///   .ply  ASCII or binary (either byte order), "vertex" x y z and "face" vertex_indices lists
///         (any integer length type); other elements and properties, lists too, are read past;
///   .off  (also COFF, NOFF... headers) one vertex per line (x y z, then ignored colours or
///         normals), one face per line (its size, that many indices, an ignored colour);
///   .stl  ASCII or binary. STL stores each triangle's corners, not shared vertices: corners at
///         exactly the same position become one vertex, numbered in the order they first occur
///         (triangle 0's three corners first), so index files refer to that order.
/// STL is read by OpenMesh into our own arrays, in single precision (as STL stores it); PLY and
/// OFF by readers of our own (OpenMesh's trusted a list's or a face's size and ran out of memory
/// on files of a few hundred bytes): OFF in double, PLY in each property's declared precision.
/// Either way vertices stay exactly in file order, every face is kept as written (non-manifold
/// ones too) and polygons are triangulated as in OBJ.
/// Throws InputError "<file>[:<line>]: <problem>" (a face index out of range names the face and corner).
enum class MeshFormat { Obj, Ply, Off, Stl };
/// The extensions read_mesh knows, for messages.
inline constexpr std::string_view kReadableMeshFormats = ".obj, .ply, .off or .stl";
/// The format a path's extension names (case-insensitive), or nullopt.
std::optional<MeshFormat> mesh_format_of(const std::filesystem::path& path);
/// Reads a mesh by its extension: OBJ, PLY, OFF or STL. Throws InputError naming the file and line.
Mesh read_mesh(const std::filesystem::path& path);
/// The same for content already in memory, the format from `path`'s extension.
Mesh parse_mesh(const std::filesystem::path& path, std::string_view content);

/// Binary little-endian PLY with double coordinates (exact), atomically.
void write_ply(const std::filesystem::path& path, const Mesh& mesh);
/// .obj or .ply by the extension; anything else throws InputError.
void write_mesh(const std::filesystem::path& path, const Mesh& mesh);

}  // namespace hdeform

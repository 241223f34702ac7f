#pragma once
// The headers of PLY and OFF files, checked strictly before OpenMesh reads the body. OpenMesh's
// readers trust the header: a count that does not parse or is larger than the file could hold
// makes them allocate until memory runs out (minutes, then std::bad_alloc), a misspelt magic
// reads garbage as a mesh, and a comment before OFF's counts is taken for the counts. Each check
// throws InputError "<file>:<line>: <problem>".
#include <filesystem>
#include <string>
#include <string_view>

namespace hdeform::detail {

// A PLY header: "ply", a known format, elements with counts and typed properties, "end_header";
// a "vertex" element with x, y and z and a "face" element with a vertex_indices (or
// vertex_index) list; counts that fit in the bytes after the header.
void check_ply_header(const std::filesystem::path& path, std::string_view content);

// An ASCII OFF file (OFF, COFF, NOFF, CNOFF, STOFF... headers) made ready for OpenMesh: the
// header and the counts checked (counts that fit in the file), comments blanked out and the
// counts moved to the line after the header, line numbers of the body unchanged.
std::string checked_off_content(const std::filesystem::path& path, std::string_view content);

}  // namespace hdeform::detail

#pragma once
// The OBJ reader's parallel path, open to tests: the content cut into pieces of about
// `piece_bytes` at line ends (never inside a continued line), parsed side by side and joined.
// The mesh is the one-pass reader's; nullopt when any piece has a problem, which the one-pass
// reader then names (so every message stays that reader's). Errors found only in the joined
// arrays (no faces, validate_mesh) are thrown as the one-pass reader throws them.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string_view>

#include "hdeform/mesh.h"

namespace hdeform::detail {

std::optional<Mesh> try_parse_obj_in_pieces(const std::filesystem::path& path, std::string_view content, std::size_t piece_bytes);

}  // namespace hdeform::detail

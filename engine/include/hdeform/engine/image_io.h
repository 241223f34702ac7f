#pragma once
#include <filesystem>

#include "hdeform/engine/render_targets.h"

namespace hdeform::engine {

/// PNG (RGBA, 8 bits), written atomically. Throws hdeform::InputError naming the path on failure.
void write_png(const std::filesystem::path& path, const Pixels& pixels);
/// Throws hdeform::InputError naming the path when the file is not a readable PNG.
Pixels read_png(const std::filesystem::path& path);

}  // namespace hdeform::engine

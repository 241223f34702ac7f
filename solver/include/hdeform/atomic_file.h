#pragma once
/// @file
/// Every file the program writes goes through here: the content is written to a temporary file
/// beside the destination and renamed over it only when complete, so an interrupted write never
/// leaves a truncated result and a failed command leaves no output at all.
#include <filesystem>
#include <functional>
#include <ostream>

namespace hdeform {

/// Writes `path` atomically; `write` fills the stream. Throws InputError naming the path when the
/// file cannot be created or written. The temporary file is removed on every failure.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

/// Removes the temporary files of writes to `path` whose process no longer runs (it was killed in
/// the middle of a write); returns how many. A write in progress elsewhere is left alone.
std::size_t remove_abandoned_temporaries(const std::filesystem::path& path);

}  // namespace hdeform

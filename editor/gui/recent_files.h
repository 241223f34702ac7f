#pragma once
// The files the editor opened last, newest first, kept beside the recovery file (recent.json)
// so that the Open box can offer them.
#include <filesystem>
#include <string>
#include <vector>

namespace hdeform::cli {

class RecentFiles {
 public:
  static constexpr std::size_t kKept = 10;

  // Reads `path` when it exists; a file that cannot be read is ignored (a list of conveniences,
  // not of the user's work).
  explicit RecentFiles(std::filesystem::path path);

  // Files that still exist, newest first.
  std::vector<std::string> list() const;
  // Puts `file` first (once), keeps the newest kKept, and writes the list (atomically; a write
  // that fails is reported on stderr and otherwise ignored).
  void add(const std::string& file);

 private:
  std::filesystem::path path_;
  std::vector<std::string> files_;
};

}  // namespace hdeform::cli

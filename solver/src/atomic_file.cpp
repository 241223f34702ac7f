#include "hdeform/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <random>

#include "hdeform/errors.h"

namespace hdeform {
namespace {

std::filesystem::path temporary_sibling(const std::filesystem::path& path) {
  std::random_device entropy;
  const auto tag = std::to_string(::getpid()) + "." + std::to_string(entropy());
  return path.parent_path() / ("." + path.filename().string() + ".tmp." + tag);
}

// Flushes the file's data to disk so that the rename never publishes an empty file after a crash.
void sync_file(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
  const auto temporary = temporary_sibling(path);
  try {
    {
      std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
      if (!out) throw InputError(path.string() + ": cannot create file (" + std::strerror(errno) + ")");
      write(out);
      out.flush();
      if (!out) throw InputError(path.string() + ": write failed (" + std::strerror(errno) + ")");
    }
    sync_file(temporary);
    std::error_code error;
    std::filesystem::rename(temporary, path, error);
    if (error) throw InputError(path.string() + ": cannot replace file (" + error.message() + ")");
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    throw;
  }
}

}  // namespace hdeform

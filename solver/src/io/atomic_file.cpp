#include "hdeform/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <random>

#include "hdeform/errors.h"

namespace hdeform {
namespace {

// ".NAME.tmp.PID.RANDOM" beside NAME: hidden, and traceable to the process writing it.
// (Appended rather than "." + name: GCC 12 warns falsely, -Wrestrict, about that operator+.)
std::string temporary_prefix(const std::filesystem::path& path) {
  std::string prefix = ".";
  prefix += path.filename().string();
  prefix += ".tmp.";
  return prefix;
}

std::filesystem::path temporary_sibling(const std::filesystem::path& path) {
  std::random_device entropy;
  const auto tag = std::to_string(::getpid()) + "." + std::to_string(entropy());
  return path.parent_path() / (temporary_prefix(path) + tag);
}

// Flushes the file's data to disk so that the rename never publishes an empty file after a crash.
void sync_file(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

std::size_t remove_abandoned_temporaries(const std::filesystem::path& path) {
  const auto prefix = temporary_prefix(path);
  const auto folder = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  std::error_code error;
  std::size_t removed = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    const auto name = entry.path().filename().string();
    if (!name.starts_with(prefix)) continue;
    const auto tag = name.substr(prefix.size());
    const auto dot = tag.find('.');
    if (dot == 0 || dot == std::string::npos || tag.find_first_not_of("0123456789") != dot) continue;
    pid_t pid = 0;
    if (std::from_chars(tag.data(), tag.data() + dot, pid).ec != std::errc()) continue;  // too large for a pid
    if (pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to judge
    if (std::filesystem::remove(entry.path(), error)) ++removed;
  }
  return removed;
}

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

#pragma once
// The readers take paths, so each fuzz input is written to a file first: the reader under test is
// exactly the one the program runs, file opening included. One file per process, reused.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include <fcntl.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include "hdeform/errors.h"

namespace hdeform::fuzz {

// The path reads the same in every process: libFuzzer's comparison tracing sees the bytes the
// readers compare, the path among them, and with a process id in the name two seeded runs of the
// same commit kept different inputs (lists, 50,000 inputs: 928 and 985 new units; in a fresh pid
// namespace each, 982 and 982). The file lies in a private folder reached through a descriptor
// with a fixed number: /proc/self/fd/N/input.EXT.
class InputFile {
 public:
  explicit InputFile(const std::string& extension) {
    std::string folder = (std::filesystem::temp_directory_path() / "hdeform-fuzz-XXXXXX").string();
    if (::mkdtemp(folder.data()) == nullptr) fail("cannot make a folder for the input: " + folder);
    folder_ = folder;
    const int descriptor = ::open(folder.c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC);
    if (descriptor < 0 || ::dup2(descriptor, kFolderDescriptor) < 0) fail("cannot open the input's folder " + folder);
    ::close(descriptor);
    path_ = "/proc/self/fd/" + std::to_string(kFolderDescriptor) + "/input" + extension;
    real_path_ = folder_ / ("input" + extension);
  }
  ~InputFile() {
    std::error_code ignored;
    std::filesystem::remove(real_path_, ignored);
    std::filesystem::remove(folder_, ignored);
  }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  static constexpr int kFolderDescriptor = 900;  // below the usual limit of 1024 open files
  [[noreturn]] static void fail(const std::string& what) {
    std::fprintf(stderr, "fuzz: %s\n", what.c_str());
    std::abort();
  }
  std::filesystem::path folder_, path_, real_path_;
};

// One thread: how a parallel loop splits its range depends on timing, and so would the coverage
// it reports, so that a seeded run would not repeat itself.
inline void run_on_one_thread() { static const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1); }

inline const std::filesystem::path& write_input(const std::uint8_t* data, std::size_t size, const std::string& extension) {
  run_on_one_thread();
  static const InputFile file(extension);
  const auto& path = file.path();
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

// A reader may refuse its input with InputError and nothing else: any other exception is a bug
// (the program would report it as an internal error), so it aborts and libFuzzer keeps the input.
template <typename Read>
void expect_clean_refusal(Read&& read) {
  try {
    read();
  } catch (const InputError&) {
  } catch (const std::exception& error) {
    std::fprintf(stderr, "reader threw something other than InputError: %s\n", error.what());
    std::abort();
  }
}

}  // namespace hdeform::fuzz

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

#include <tbb/global_control.h>
#include <unistd.h>

#include "hdeform/errors.h"

namespace hdeform::fuzz {

class InputFile {
 public:
  // The name has the same length in every process: messages quote it, and a length that varied
  // with the pid would vary the coverage, so that a seeded run would not repeat itself.
  explicit InputFile(const std::string& extension) : path_(std::filesystem::temp_directory_path() / name(extension)) {}
  ~InputFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  static std::string name(const std::string& extension) {
    char pid[16];
    std::snprintf(pid, sizeof pid, "%010d", static_cast<int>(::getpid()));
    return "hdeform-fuzz-" + std::string(pid) + extension;
  }
  std::filesystem::path path_;
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

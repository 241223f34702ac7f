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

#include <unistd.h>

#include "hdeform/errors.h"

namespace hdeform::fuzz {

class InputFile {
 public:
  explicit InputFile(const std::string& extension)
      : path_(std::filesystem::temp_directory_path() / ("hdeform-fuzz-" + std::to_string(::getpid()) + extension)) {}
  ~InputFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

inline const std::filesystem::path& write_input(const std::uint8_t* data, std::size_t size, const std::string& extension) {
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

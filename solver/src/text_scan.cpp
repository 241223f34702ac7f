#include "text_scan.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

namespace hdeform::detail {

std::string read_text_file(const std::filesystem::path& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) throw InputError(path.string() + ": is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open file (" + std::strerror(errno) + ")");
  std::ostringstream content;
  content << in.rdbuf();
  if (in.bad()) throw InputError(path.string() + ": read failed");
  return std::move(content).str();
}

void fail_at(const std::filesystem::path& path, std::size_t line, const std::string& problem) {
  throw InputError(path.string() + ":" + std::to_string(line) + ": " + problem);
}

void reject_binary(const std::filesystem::path& path, std::string_view content) {
  for_each_raw_line(content, [&](std::size_t line, std::string_view text) {
    for (const char c : text) {
      const auto byte = static_cast<unsigned char>(c);
      if (byte < 0x20 && !is_blank(c)) {
        fail_at(path, line, "binary data (byte 0x" + std::string(1, "0123456789abcdef"[byte >> 4]) +
                                std::string(1, "0123456789abcdef"[byte & 15]) + "), not a text file");
      }
    }
  });
}

std::string quoted(std::string_view token) {
  constexpr std::size_t kShown = 40;
  std::string shown(token.substr(0, kShown));
  if (token.size() > kShown) shown += "...";
  return "'" + shown + "'";
}

}  // namespace hdeform::detail

#include "text_scan.h"

#include <algorithm>
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
  // Read in one piece when the size is known (a stream buffer copies twice); a file whose size
  // is not known in advance (a pipe, /proc) is read through the stream.
  const auto size = std::filesystem::is_regular_file(path, error) ? std::filesystem::file_size(path, error) : std::uintmax_t{0};
  std::string content;
  if (!error && size > 0) {
    content.resize(static_cast<std::size_t>(size));
    in.read(content.data(), static_cast<std::streamsize>(content.size()));
    content.resize(static_cast<std::size_t>(in.gcount()));
    if (in.bad()) throw InputError(path.string() + ": read failed");
    if (in.eof()) return content;  // shrank while read: what there was
    in.clear();
  }
  std::ostringstream rest;
  rest << in.rdbuf();
  if (in.bad()) throw InputError(path.string() + ": read failed");
  content += std::move(rest).str();
  return content;
}

void fail_at(const std::filesystem::path& path, std::size_t line, const std::string& problem) {
  throw InputError(path.string() + ":" + std::to_string(line) + ": " + problem);
}

void reject_binary(const std::filesystem::path& path, std::string_view content) {
  // Text files are nearly all this reader sees: one pass without branches (vectorised) tells,
  // and only binary content is walked line by line to name the line.
  constexpr std::size_t kBlock = 1 << 16;
  bool control = false;
  for (std::size_t first = 0; first < content.size() && !control; first += kBlock) {
    const std::size_t last = std::min(content.size(), first + kBlock);
    unsigned found = 0;
    for (std::size_t i = first; i < last; ++i) {
      const auto byte = static_cast<unsigned char>(content[i]);
      found |= static_cast<unsigned>(byte < 0x20 && byte != '\t' && byte != '\n' && byte != '\v' && byte != '\f' && byte != '\r');
    }
    control = found != 0;
  }
  if (!control) return;
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

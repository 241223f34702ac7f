#pragma once
// Line and token scanning shared by every text reader, so that all of them report problems the
// same way: "<file>:<line>: <problem>".
#include <charconv>
#include <cstdlib>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "hdeform/errors.h"

namespace hdeform::detail {

// Reads a whole file; throws InputError naming the file when it cannot be read.
std::string read_text_file(const std::filesystem::path& path);

[[noreturn]] void fail_at(const std::filesystem::path& path, std::size_t line, const std::string& problem);

// Throws when the content holds bytes that never occur in a text file (NUL and most control
// characters), naming the first such line: binary garbage gets one clear message.
void reject_binary(const std::filesystem::path& path, std::string_view content);

// Calls visit(line_number, line) for each line with the '#' comment and trailing '\r' removed.
template <class Visit>
void for_each_line(std::string_view content, Visit&& visit) {
  std::size_t line_number = 0;
  std::size_t start = 0;
  while (start < content.size()) {
    std::size_t end = content.find('\n', start);
    if (end == std::string_view::npos) end = content.size();
    std::string_view line = content.substr(start, end - start);
    if (const auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    visit(++line_number, line);
    start = end + 1;
  }
}

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// Splits on blanks into `tokens` (cleared first; capacity reused).
inline void split_tokens(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_blank(line[i])) ++i;
    const std::size_t begin = i;
    while (i < line.size() && !is_blank(line[i])) ++i;
    if (i > begin) tokens.push_back(line.substr(begin, i - begin));
  }
}

// Parses the whole token as a number; nullopt when it is not one. NaN and infinities parse
// (as such) so that callers can name them as non-finite rather than as garbage.
inline std::optional<double> parse_double(std::string_view token) {
  double value = 0.0;
  const char* begin = token.data();
  if (!token.empty() && token.front() == '+') ++begin;
  const auto [end, error] = std::from_chars(begin, token.data() + token.size(), value);
  if (error == std::errc::result_out_of_range && end == token.data() + token.size()) {
    // strtod saturates the way a reader expects: overflow to an infinity (reported as
    // non-finite by the caller), underflow to zero.
    return std::strtod(std::string(token).c_str(), nullptr);
  }
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

inline std::optional<long long> parse_integer(std::string_view token) {
  long long value = 0;
  const char* begin = token.data();
  if (!token.empty() && token.front() == '+') ++begin;
  const auto [end, error] = std::from_chars(begin, token.data() + token.size(), value);
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

std::string quoted(std::string_view token);

}  // namespace hdeform::detail

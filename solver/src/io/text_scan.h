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

// What a line end is, for every reader (decided here and nowhere else): LF, CRLF and a lone CR
// (old Mac files) each end a line, so a file reads the same whichever it uses, and line numbers
// count them alike. A UTF-8 byte-order mark at the start of the content is skipped.
// Calls visit(line_number, raw_line) for each physical line, without its line end.
template <class Visit>
void for_each_raw_line(std::string_view content, Visit&& visit) {
  if (content.starts_with("\xEF\xBB\xBF")) content.remove_prefix(3);
  std::size_t line_number = 0;
  std::size_t start = 0;
  while (start < content.size()) {
    // A plain loop: find_first_of tests each byte against the set through a call.
    std::size_t end = start;
    while (end < content.size() && content[end] != '\n' && content[end] != '\r') ++end;
    visit(++line_number, content.substr(start, end - start));
    start = end + 1;
    if (end < content.size() && content[end] == '\r' && start < content.size() && content[start] == '\n') ++start;
  }
}

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\f' || c == '\v'; }

inline std::string_view trim_trailing_blanks(std::string_view text) {
  while (!text.empty() && is_blank(text.back())) text.remove_suffix(1);
  return text;
}

// Calls visit(line_number, line) for each logical line: a physical line with its '#' comment
// removed, joined with the next one when it then ends in a backslash (the OBJ continuation; the
// backslash becomes a blank). The number is that of the line's first physical line.
template <class Visit>
void for_each_line(std::string_view content, Visit&& visit) {
  std::string joined;  // only used across continuations
  std::size_t joined_start = 0;
  for_each_raw_line(content, [&](std::size_t line_number, std::string_view line) {
    if (const auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    line = trim_trailing_blanks(line);
    const bool continues = !line.empty() && line.back() == '\\';
    if (continues) line.remove_suffix(1);
    if (continues || !joined.empty()) {
      if (joined.empty()) joined_start = line_number;
      joined.append(line);
      joined += ' ';
      if (continues) return;
      visit(joined_start, std::string_view(joined));
      joined.clear();
      return;
    }
    visit(line_number, line);
  });
  if (!joined.empty()) visit(joined_start, std::string_view(joined));  // a backslash on the last line
}

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
  if (token.starts_with('+')) {
    if (token.starts_with("+-")) return std::nullopt;  // from_chars would take the '-'
    ++begin;
  }
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
  if (token.starts_with('+')) {
    if (token.starts_with("+-")) return std::nullopt;
    ++begin;
  }
  const auto [end, error] = std::from_chars(begin, token.data() + token.size(), value);
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

// A count: a non-negative integer below 2^31 (an int indexes what it counts).
inline std::optional<std::size_t> parse_count(std::string_view token) {
  const auto value = parse_integer(token);
  if (!value || *value < 0 || *value > 0x7fffffff) return std::nullopt;
  return static_cast<std::size_t>(*value);
}

std::string quoted(std::string_view token);

}  // namespace hdeform::detail

#include "json_locate.h"

#include <cctype>
#include <nlohmann/json.hpp>
#include <vector>

namespace hdeform::cli {
namespace {

// A minimal scanner over valid JSON that tracks the pointer of every value it starts.
class Scanner {
 public:
  Scanner(std::string_view text, std::string_view target) : text_(text), target_(target) {}

  std::size_t run() {
    skip_blank();
    value("");
    return found_;
  }

 private:
  void skip_blank() {
    while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_]))) {
      if (text_[at_] == '\n') ++line_;
      ++at_;
    }
  }

  std::string string_token() {
    std::string out;
    ++at_;  // opening quote
    while (at_ < text_.size() && text_[at_] != '"') {
      if (text_[at_] == '\\' && at_ + 1 < text_.size()) {
        const char escaped = text_[++at_];
        out += escaped == 'n' ? '\n' : escaped == 't' ? '\t' : escaped;  // enough to compare keys
      } else {
        out += text_[at_];
      }
      ++at_;
    }
    ++at_;  // closing quote
    return out;
  }

  static std::string escape_pointer_token(const std::string& key) {
    std::string out;
    for (const char c : key) out += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
    return out;
  }

  void value(const std::string& pointer) {
    if (found_ != 0) return;
    if (pointer == target_) {
      found_ = line_;
      return;
    }
    if (at_ >= text_.size()) return;
    const char c = text_[at_];
    if (c == '{') {
      ++at_;
      skip_blank();
      while (at_ < text_.size() && text_[at_] != '}' && found_ == 0) {
        const std::string key = string_token();
        skip_blank();
        ++at_;  // ':'
        skip_blank();
        value(pointer + "/" + escape_pointer_token(key));
        skip_blank();
        if (at_ < text_.size() && text_[at_] == ',') ++at_;
        skip_blank();
      }
      ++at_;
    } else if (c == '[') {
      ++at_;
      skip_blank();
      for (std::size_t index = 0; at_ < text_.size() && text_[at_] != ']' && found_ == 0; ++index) {
        value(pointer + "/" + std::to_string(index));
        skip_blank();
        if (at_ < text_.size() && text_[at_] == ',') ++at_;
        skip_blank();
      }
      ++at_;
    } else if (c == '"') {
      string_token();
    } else {
      while (at_ < text_.size() && text_[at_] != ',' && text_[at_] != ']' && text_[at_] != '}' &&
             !std::isspace(static_cast<unsigned char>(text_[at_]))) {
        ++at_;
      }
    }
  }

  std::string_view text_;
  std::string_view target_;
  std::size_t at_ = 0;
  std::size_t line_ = 1;
  std::size_t found_ = 0;
};

}  // namespace

std::size_t json_line_of(std::string_view text, std::string_view pointer) { return Scanner(text, pointer).run(); }

std::size_t line_of_offset(std::string_view text, std::size_t offset) {
  std::size_t line = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') ++line;
  }
  return line;
}

}  // namespace hdeform::cli

#pragma once
// nlohmann::json keeps no source positions; this finds the line of a value by its JSON pointer
// in the (already valid) text, so that errors found after parsing can still name the line.
#include <string>
#include <string_view>

namespace hdeform::cli {

// 1-based line where the value at `pointer` (e.g. "/current/handles/1/vertices/3") starts, or 0.
std::size_t json_line_of(std::string_view text, std::string_view pointer);

// 1-based line of a byte offset.
std::size_t line_of_offset(std::string_view text, std::size_t offset);

}  // namespace hdeform::cli

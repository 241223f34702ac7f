#pragma once
/// @file
/// A count and its noun as the messages say it ("1 vertex", "2 vertices"): one definition for
/// the library's warnings and errors, the commands and the editor.
#include <cstddef>
#include <string>
#include <string_view>

namespace hdeform {

/// `count` followed by `one` when it is 1, by `many` otherwise.
inline std::string counted(std::size_t count, std::string_view one, std::string_view many) {
  std::string text = std::to_string(count);
  text += ' ';
  text += count == 1 ? one : many;
  return text;
}

}  // namespace hdeform

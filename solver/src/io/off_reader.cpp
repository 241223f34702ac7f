#include "mesh_readers.h"

#include <algorithm>
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "polygons.h"
#include "text_scan.h"

// OFF, read here rather than by OpenMesh: see mesh_readers.h.
namespace hdeform::detail {

Mesh parse_off(const std::filesystem::path& path, std::string_view content) {
  reject_binary(path, content);
  // The header keyword and the three counts: the first four tokens, on one line or several.
  // Copied: a line joined by a continuation lives in a buffer the next continuation reuses.
  std::vector<std::pair<std::size_t, std::string>> words;
  std::array<std::size_t, 3> counts{};
  std::vector<std::array<double, 3>> points;
  Polygons polygons;
  std::vector<int> corners;
  std::vector<std::string_view> tokens;
  std::size_t last_line = 0;
  auto number = [&](std::size_t line, std::string_view token) {
    const auto value = parse_double(token);
    if (!value) fail_at(path, line, quoted(token) + " is not a number");
    return *value;
  };
  for_each_line(content, [&](std::size_t line, std::string_view text) {
    split_tokens(text, tokens);
    if (tokens.empty()) return;
    last_line = line;
    std::size_t first = 0;
    while (words.size() < 4 && first < tokens.size()) words.emplace_back(line, std::string(tokens[first++]));
    if (words.size() < 4) {
      if (words.size() == 2 && words[1].second == "BINARY") fail_at(path, line, "binary OFF is not read (ASCII OFF only)");
      return;
    }
    if (first > 0) {  // the line that completed the header
      const std::string_view header = words[0].second;
      const bool known = header == "OFF" || header == "COFF" || header == "NOFF" || header == "CNOFF" || header == "STOFF" ||
                         header == "STCOFF" || header == "STNOFF" || header == "STCNOFF";
      if (!known) {
        fail_at(path, words[0].first, "not an OFF file (it must start with OFF, COFF, NOFF, CNOFF or STOFF; found " + quoted(header) + ")");
      }
      for (std::size_t k = 0; k < 3; ++k) {
        const auto count = parse_count(words[k + 1].second);
        if (!count) {
          if (k == 0 && words[1].second == "BINARY") fail_at(path, words[1].first, "binary OFF is not read (ASCII OFF only)");
          fail_at(path, words[k + 1].first, quoted(std::string_view(words[k + 1].second)) + " is not a count (vertices, faces, edges)");
        }
        counts[k] = *count;
      }
      if (counts[1] == 0) fail_at(path, words[2].first, "the OFF file has no faces");
      // Each vertex and face takes a line of its own: more than the file has is refused here,
      // before anything is reserved.
      if (counts[0] + counts[1] > content.size() / 2) {
        fail_at(path, line, "the header declares more than the file holds (" + std::to_string(counts[0]) + " vertices and " +
                                std::to_string(counts[1]) + " faces in " + std::to_string(content.size()) + " bytes)");
      }
      points.reserve(counts[0]);
      if (first < tokens.size()) fail_at(path, line, "the counts line holds more than three counts");
      return;
    }
    if (points.size() < counts[0]) {  // a vertex: x y z, then colours or normals (ignored)
      if (tokens.size() < 3) fail_at(path, line, "vertex " + std::to_string(points.size()) + " needs 3 coordinates, found " + std::to_string(tokens.size()));
      points.push_back({number(line, tokens[0]), number(line, tokens[1]), number(line, tokens[2])});
      return;
    }
    if (polygons.count() < counts[1]) {  // a face: its size, its indices, then a colour (ignored)
      const auto size = parse_count(tokens[0]);
      if (!size) fail_at(path, line, "face " + std::to_string(polygons.count()) + " size " + quoted(tokens[0]) + " is not a count");
      if (*size < 3) fail_at(path, line, "face " + std::to_string(polygons.count()) + " has " + std::to_string(*size) + " vertices (at least 3 are needed)");
      if (*size > tokens.size() - 1) {
        fail_at(path, line, "face " + std::to_string(polygons.count()) + " declares " + std::to_string(*size) + " vertices but its line holds " +
                                std::to_string(tokens.size() - 1) + " numbers (one face per line)");
      }
      corners.clear();
      for (std::size_t k = 1; k <= *size; ++k) {
        const auto index = parse_integer(tokens[k]);
        if (!index) fail_at(path, line, "face " + std::to_string(polygons.count()) + ": " + quoted(tokens[k]) + " is not a vertex index");
        if (*index < 0 || *index >= static_cast<long long>(counts[0])) {
          fail_at(path, line, "face " + std::to_string(polygons.count()) + " corner " + std::to_string(k - 1) + " has vertex index " +
                                  std::to_string(*index) + ", out of range (" + std::to_string(counts[0]) + " vertices)");
        }
        corners.push_back(static_cast<int>(*index));
      }
      polygons.add(corners.data(), corners.size());
    }
    // Anything after the faces (the edges some writers list) is not read.
  });
  if (words.size() < 4) fail_at(path, std::max<std::size_t>(last_line, 1), words.empty() ? "an empty OFF file" : "the OFF header needs three counts: vertices, faces and edges");
  if (points.size() < counts[0] || polygons.count() < counts[1]) {
    fail_at(path, last_line, "the file ends after " + std::to_string(points.size()) + " of " + std::to_string(counts[0]) + " vertices and " +
                                 std::to_string(polygons.count()) + " of " + std::to_string(counts[1]) + " faces");
  }
  return mesh_of(points, polygons, path.string());
}

}  // namespace hdeform::detail

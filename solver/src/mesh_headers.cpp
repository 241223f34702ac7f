#include "mesh_headers.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <optional>
#include <vector>

#include "polygons.h"
#include "text_scan.h"

namespace hdeform::detail {
namespace {

// Size in bytes of a PLY scalar type, or nothing for an unknown name.
std::optional<std::size_t> ply_type_size(std::string_view type) {
  static constexpr std::array<std::pair<std::string_view, std::size_t>, 16> kTypes{{
      {"char", 1}, {"uchar", 1}, {"int8", 1}, {"uint8", 1}, {"short", 2}, {"ushort", 2}, {"int16", 2}, {"uint16", 2},
      {"int", 4}, {"uint", 4}, {"int32", 4}, {"uint32", 4}, {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}}};
  for (const auto& [name, size] : kTypes) {
    if (name == type) return size;
  }
  return std::nullopt;
}

std::vector<std::string_view> tokens_of(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t start = 0;
  while (true) {
    start = line.find_first_not_of(" \t", start);
    if (start == std::string_view::npos) break;
    const std::size_t end = std::min(line.find_first_of(" \t", start), line.size());
    tokens.push_back(line.substr(start, end - start));
    start = end;
  }
  return tokens;
}

// A count: a non-negative integer below 2^31.
std::optional<std::size_t> parse_count(std::string_view token) {
  const auto value = parse_integer(token);
  if (!value || *value < 0 || *value > 0x7fffffff) return std::nullopt;
  return static_cast<std::size_t>(*value);
}

struct PlyElement {
  std::string_view name;
  std::size_t count = 0;
  std::size_t line = 0;
  std::size_t fixed_bytes = 0;  // the scalar properties, and the length of each list
  std::size_t properties = 0;
  std::vector<std::string_view> scalar_names;
  std::vector<std::string_view> list_names;
  std::vector<std::size_t> longest_lists;  // per property in order: 0 for a scalar, else what its length type holds
};

// An ASCII body writes a list's length as text, which its type does not bound, and OpenMesh reads
// as many items as the length says, whatever follows (a 228-byte file asking for 7.8e17 items ran
// until the fuzzer's timeout). Each length is checked here first; a body that ends early is left to
// the reader, which reports it.
void check_ascii_list_lengths(const std::filesystem::path& path, std::string_view body, std::size_t first_line,
                              const std::vector<PlyElement>& elements) {
  std::size_t position = 0;
  std::size_t line = first_line;
  auto next_token = [&]() -> std::optional<std::string_view> {
    while (position < body.size() && std::isspace(static_cast<unsigned char>(body[position]))) {
      if (body[position] == '\n') ++line;
      ++position;
    }
    if (position == body.size()) return std::nullopt;
    const std::size_t start = position;
    while (position < body.size() && !std::isspace(static_cast<unsigned char>(body[position]))) ++position;
    return body.substr(start, position - start);
  };
  for (const auto& element : elements) {
    for (std::size_t item = 0; item < element.count; ++item) {
      for (const std::size_t longest : element.longest_lists) {
        const auto token = next_token();
        if (!token) return;
        if (longest == 0) continue;
        const auto length = parse_count(*token);
        if (!length || *length > longest) {
          fail_at(path, line, "element " + quoted(element.name) + " item " + std::to_string(item) + " has a list of length " +
                                  quoted(*token) + " (its length type holds 0 to " + std::to_string(longest) + ")");
        }
        for (std::size_t i = 0; i < *length; ++i) {
          if (!next_token()) return;
        }
      }
    }
  }
}

}  // namespace

void check_ply_header(const std::filesystem::path& path, std::string_view content) {
  std::vector<PlyElement> elements;
  bool binary = false;
  bool format_seen = false;
  std::size_t position = 0;
  std::size_t line_number = 0;
  std::optional<std::size_t> body_start;
  while (position < content.size() && !body_start) {
    std::size_t end = content.find('\n', position);
    if (end == std::string_view::npos) end = content.size();
    std::string_view line = content.substr(position, end - position);
    if (line.ends_with('\r')) line.remove_suffix(1);
    position = end + 1;
    ++line_number;
    const auto tokens = tokens_of(line);
    if (line_number == 1) {
      if (tokens.size() != 1 || tokens[0] != "ply") fail_at(path, 1, "not a PLY file (it must start with the line \"ply\")");
      continue;
    }
    if (tokens.empty()) continue;
    const auto keyword = tokens[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "format") {
      if (tokens.size() != 3 || (tokens[1] != "ascii" && tokens[1] != "binary_little_endian" && tokens[1] != "binary_big_endian")) {
        fail_at(path, line_number, "unknown PLY format " + quoted(line) + " (ascii, binary_little_endian or binary_big_endian)");
      }
      if (tokens[2] != "1.0") fail_at(path, line_number, "PLY version " + quoted(tokens[2]) + " (only 1.0 exists)");
      binary = tokens[1] != "ascii";
      format_seen = true;
    } else if (keyword == "element") {
      if (tokens.size() != 3) fail_at(path, line_number, "an element needs a name and a count: " + quoted(line));
      const auto count = parse_count(tokens[2]);
      if (!count) fail_at(path, line_number, "element " + quoted(tokens[1]) + " has count " + quoted(tokens[2]) + ", not a count");
      PlyElement element;
      element.name = tokens[1];
      element.count = *count;
      element.line = line_number;
      elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (elements.empty()) fail_at(path, line_number, "a property before any element");
      auto& element = elements.back();
      if (tokens.size() == 5 && tokens[1] == "list") {
        const auto length_size = ply_type_size(tokens[2]);
        if (!length_size || !ply_type_size(tokens[3])) fail_at(path, line_number, "unknown property type in " + quoted(line));
        // OpenMesh reads as many items as a list's length says, whatever the file holds: a 4-byte
        // length could ask for billions. One or two bytes are what PLY writers use.
        if (*length_size > 2) {
          fail_at(path, line_number, "list lengths of type " + quoted(tokens[2]) + " are not read (uchar or ushort)");
        }
        element.fixed_bytes += *length_size;
        element.list_names.push_back(tokens[4]);
        element.longest_lists.push_back(*length_size == 1 ? 255 : 65535);
      } else if (tokens.size() == 3) {
        const auto size = ply_type_size(tokens[1]);
        if (!size) fail_at(path, line_number, "unknown property type " + quoted(tokens[1]));
        element.fixed_bytes += *size;
        element.scalar_names.push_back(tokens[2]);
        element.longest_lists.push_back(0);
      } else {
        fail_at(path, line_number, "a property needs a type and a name: " + quoted(line));
      }
      ++element.properties;
    } else if (keyword == "end_header") {
      body_start = position;
    } else {
      fail_at(path, line_number, "unknown PLY header line " + quoted(line));
    }
  }
  if (!body_start) fail_at(path, line_number, "the PLY header has no end_header line");
  if (!format_seen) fail_at(path, line_number, "the PLY header has no format line");

  const PlyElement* vertex = nullptr;
  const PlyElement* face = nullptr;
  std::size_t least_bytes = 0;  // what the body must hold at the least
  for (const auto& element : elements) {
    if (element.name == "vertex") vertex = &element;
    if (element.name == "face") face = &element;
    // ASCII: a value and a separator per property; binary: the fixed bytes (lists may be empty).
    least_bytes += element.count * (binary ? element.fixed_bytes : 2 * element.properties);
  }
  auto has = [](const std::vector<std::string_view>& names, std::string_view name) {
    return std::find(names.begin(), names.end(), name) != names.end();
  };
  if (!vertex) fail_at(path, line_number, "the PLY header has no vertex element");
  for (const char* axis : {"x", "y", "z"}) {
    if (!has(vertex->scalar_names, axis)) fail_at(path, vertex->line, std::string("the vertex element has no property ") + axis);
  }
  if (!face || face->count == 0) fail_at(path, line_number, "the PLY file has no faces");
  if (!has(face->list_names, "vertex_indices") && !has(face->list_names, "vertex_index")) {
    fail_at(path, face->line, "the face element has no vertex_indices list");
  }
  const std::size_t body = content.size() - *body_start;
  if (least_bytes > body) {
    fail_at(path, line_number, "the header declares more than the file holds (" + std::to_string(vertex->count) + " vertices and " +
                                   std::to_string(face->count) + " faces need at least " + std::to_string(least_bytes) +
                                   " bytes; " + std::to_string(body) + " follow the header)");
  }
  if (!binary) check_ascii_list_lengths(path, content.substr(std::min(*body_start, content.size())), line_number + 1, elements);
}

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
  Mesh mesh;
  mesh.positions.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t v = 0; v < points.size(); ++v) {
    for (int c = 0; c < 3; ++c) mesh.positions(static_cast<Eigen::Index>(v), c) = points[v][static_cast<std::size_t>(c)];
  }
  triangulate(polygons, mesh.positions, mesh.triangles);
  validate_mesh(mesh, path.string());
  return mesh;
}

}  // namespace hdeform::detail

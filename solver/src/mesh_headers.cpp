#include "mesh_headers.h"

#include <algorithm>
#include <array>
#include <optional>
#include <vector>

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
};

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
      } else if (tokens.size() == 3) {
        const auto size = ply_type_size(tokens[1]);
        if (!size) fail_at(path, line_number, "unknown property type " + quoted(tokens[1]));
        element.fixed_bytes += *size;
        element.scalar_names.push_back(tokens[2]);
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
}

std::string checked_off_content(const std::filesystem::path& path, std::string_view content) {
  // Comments blanked (from '#' to the line end), so that they count as white space everywhere.
  std::string text(content);
  for (std::size_t k = 0; k < text.size(); ++k) {
    if (text[k] != '#') continue;
    while (k < text.size() && text[k] != '\n' && text[k] != '\r') text[k++] = ' ';
  }
  reject_binary(path, text);
  std::vector<std::pair<std::size_t, std::string_view>> words;  // line, token: the first four
  std::size_t body_start = text.size();
  for_each_raw_line(text, [&](std::size_t line, std::string_view raw) {
    if (words.size() >= 4) return;
    for (const auto token : tokens_of(raw)) {
      if (words.size() < 4) words.emplace_back(line, token);
    }
    if (words.size() >= 4) body_start = static_cast<std::size_t>(raw.data() + raw.size() - text.data());
  });
  if (words.empty()) fail_at(path, 1, "an empty OFF file");
  const auto [header_line, header] = words[0];
  const bool known = header == "OFF" || header == "COFF" || header == "NOFF" || header == "CNOFF" || header == "STOFF" ||
                     header == "STCOFF" || header == "STNOFF" || header == "STCNOFF";
  if (!known) {
    fail_at(path, header_line, "not an OFF file (it must start with OFF, COFF, NOFF, CNOFF or STOFF; found " + quoted(header) + ")");
  }
  if (words.size() < 4) fail_at(path, words.back().first, "the OFF header needs three counts: vertices, faces and edges");
  std::array<std::size_t, 3> counts{};
  for (std::size_t k = 0; k < 3; ++k) {
    const auto count = parse_count(words[k + 1].second);
    if (!count) {
      if (k == 0 && words[1].second == "BINARY") fail_at(path, words[1].first, "binary OFF is not read (ASCII OFF only)");
      fail_at(path, words[k + 1].first, quoted(words[k + 1].second) + " is not a count (vertices, faces, edges)");
    }
    counts[k] = *count;
  }
  if (counts[1] == 0) fail_at(path, words[2].first, "the OFF file has no faces");
  // Three coordinates per vertex and four numbers per face at the least, each a digit and a space.
  const std::size_t least_bytes = 6 * counts[0] + 8 * counts[1];
  const std::size_t body = text.size() - body_start;
  if (least_bytes > body) {
    fail_at(path, words[3].first, "the header declares more than the file holds (" + std::to_string(counts[0]) + " vertices and " +
                                      std::to_string(counts[1]) + " faces need at least " + std::to_string(least_bytes) + " bytes; " +
                                      std::to_string(body) + " follow the counts)");
  }
  // OpenMesh reads as many indices as a face's count says, whatever the file holds (a count of
  // 9·10¹⁰ allocated until memory ran out), so each face line must hold its count's indices. The
  // vertices come first, one non-blank line each.
  std::size_t seen = 0;
  for_each_raw_line(std::string_view(text).substr(body_start), [&](std::size_t line, std::string_view raw) {
    const auto tokens = tokens_of(raw);
    if (tokens.empty() || seen >= counts[0] + counts[1]) return;
    const std::size_t index = seen++;
    if (index < counts[0]) return;  // a vertex
    const std::size_t face = index - counts[0];
    const auto size = parse_count(tokens[0]);
    if (!size || *size > tokens.size() - 1) {
      fail_at(path, words[3].first + line - 1,
              "face " + std::to_string(face) + " declares " + quoted(tokens[0]) + " vertices but its line holds " +
                  std::to_string(tokens.size() - 1) + " numbers (one face per line)");
    }
  });
  // OpenMesh wants the header token on the first line and the counts on the next; the body keeps
  // its lines.
  return std::string(header) + "\n" + std::to_string(counts[0]) + " " + std::to_string(counts[1]) + " " + std::to_string(counts[2]) +
         text.substr(body_start);
}

}  // namespace hdeform::detail

// PLY, read here rather than by OpenMesh. OpenMesh 9 parses the header by rules of its own (the
// words of an obj_info line become keywords), reads a list in any element but the faces as one
// value, and takes an ASCII list's length from whatever token it meets there: once its walk and
// our header check's parted, a value the check had skipped became a face's size (CI's fuzz run
// stopped at 2 GB; a 231-byte file whose vertices carry a list does it too, now a seed). Here one
// parsed header drives the body, and a list longer than the rest of the file could hold is
// refused before anything is reserved.
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hdeform/errors.h"
#include "mesh_readers.h"
#include "polygons.h"
#include "text_scan.h"

namespace hdeform::detail {
namespace {

struct PlyType {
  std::string_view name;
  std::size_t size = 0;  // in bytes, in a binary body
  bool is_float = false;
  bool is_signed = false;

  long long largest() const { return is_signed ? (1LL << (8 * size - 1)) - 1 : (1LL << (8 * size)) - 1; }
};

std::optional<PlyType> ply_type(std::string_view name) {
  static constexpr std::array<PlyType, 16> kTypes{{{"char", 1, false, true},    {"uchar", 1, false, false},  {"int8", 1, false, true},
                                                   {"uint8", 1, false, false},  {"short", 2, false, true},   {"ushort", 2, false, false},
                                                   {"int16", 2, false, true},   {"uint16", 2, false, false}, {"int", 4, false, true},
                                                   {"uint", 4, false, false},   {"int32", 4, false, true},   {"uint32", 4, false, false},
                                                   {"float", 4, true, true},    {"float32", 4, true, true},  {"double", 8, true, true},
                                                   {"float64", 8, true, true}}};
  for (const auto& type : kTypes) {
    if (type.name == name) return type;
  }
  return std::nullopt;
}

struct PlyProperty {
  std::string_view name;
  std::size_t line = 0;
  PlyType value;
  std::optional<PlyType> length;  // a list's length type
};

struct PlyElement {
  std::string_view name;
  std::size_t count = 0;
  std::size_t line = 0;
  std::vector<PlyProperty> properties;

  std::optional<std::size_t> find(std::string_view property) const {
    for (std::size_t p = 0; p < properties.size(); ++p) {
      if (properties[p].name == property) return p;
    }
    return std::nullopt;
  }
};

enum class PlyEncoding { Ascii, LittleEndian, BigEndian };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::Ascii;
  std::vector<PlyElement> elements;
  std::size_t body_start = 0;  // the offset of the body's first byte
  std::size_t body_line = 0;   // the number of the body's first line
  std::size_t vertex = 0;      // the indices of the elements a mesh is made of
  std::size_t face = 0;
  std::array<std::size_t, 3> coordinates{};  // x, y and z among the vertex's properties
  std::size_t corners = 0;                    // the vertex_indices list among the face's
};

PlyProperty parse_property(const std::filesystem::path& path, std::size_t line_number, std::string_view line,
                           const std::vector<std::string_view>& tokens) {
  PlyProperty property;
  property.line = line_number;
  if (tokens.size() == 5 && tokens[1] == "list") {
    const auto length = ply_type(tokens[2]);
    const auto value = ply_type(tokens[3]);
    if (!length || !value) fail_at(path, line_number, "unknown property type in " + quoted(line));
    if (length->is_float) fail_at(path, line_number, "a list length of type " + quoted(tokens[2]) + " (an integer type is needed)");
    property.length = length;
    property.value = *value;
    property.name = tokens[4];
  } else if (tokens.size() == 3) {
    const auto value = ply_type(tokens[1]);
    if (!value) fail_at(path, line_number, "unknown property type " + quoted(tokens[1]));
    property.value = *value;
    property.name = tokens[2];
  } else {
    fail_at(path, line_number, "a property needs a type and a name: " + quoted(line));
  }
  return property;
}

PlyHeader parse_ply_header(const std::filesystem::path& path, std::string_view content) {
  PlyHeader header;
  bool format_seen = false;
  bool ended = false;
  std::size_t position = 0;
  std::size_t line_number = 0;
  std::vector<std::string_view> tokens;
  while (position < content.size() && !ended) {
    std::size_t end = content.find('\n', position);
    if (end == std::string_view::npos) end = content.size();
    std::string_view line = content.substr(position, end - position);
    if (line.ends_with('\r')) line.remove_suffix(1);
    position = std::min(end + 1, content.size());
    ++line_number;
    split_tokens(line, tokens);
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
      header.encoding = tokens[1] == "ascii" ? PlyEncoding::Ascii : tokens[1] == "binary_little_endian" ? PlyEncoding::LittleEndian : PlyEncoding::BigEndian;
      format_seen = true;
    } else if (keyword == "element") {
      if (tokens.size() != 3) fail_at(path, line_number, "an element needs a name and a count: " + quoted(line));
      const auto count = parse_count(tokens[2]);
      if (!count) fail_at(path, line_number, "element " + quoted(tokens[1]) + " has count " + quoted(tokens[2]) + ", not a count");
      for (const auto& earlier : header.elements) {
        if (earlier.name == tokens[1]) {
          fail_at(path, line_number, "a second element " + quoted(tokens[1]) + " (the first is on line " + std::to_string(earlier.line) + ")");
        }
      }
      header.elements.push_back({tokens[1], *count, line_number, {}});
    } else if (keyword == "property") {
      if (header.elements.empty()) fail_at(path, line_number, "a property before any element");
      header.elements.back().properties.push_back(parse_property(path, line_number, line, tokens));
    } else if (keyword == "end_header") {
      ended = true;
    } else {
      fail_at(path, line_number, "unknown PLY header line " + quoted(line));
    }
  }
  if (!ended) fail_at(path, line_number, "the PLY header has no end_header line");
  if (!format_seen) fail_at(path, line_number, "the PLY header has no format line");
  header.body_start = position;
  header.body_line = line_number + 1;

  const PlyElement* vertex = nullptr;
  const PlyElement* face = nullptr;
  const bool binary = header.encoding != PlyEncoding::Ascii;
  std::size_t least_bytes = 0;  // what the body must hold at the least
  for (std::size_t e = 0; e < header.elements.size(); ++e) {
    const auto& element = header.elements[e];
    if (element.name == "vertex") vertex = &element, header.vertex = e;
    if (element.name == "face") face = &element, header.face = e;
    // ASCII: a value and a separator per property; binary: each scalar, and each list's length.
    std::size_t item_bytes = 0;
    for (const auto& property : element.properties) item_bytes += binary ? (property.length ? property.length->size : property.value.size) : 2;
    least_bytes += element.count * item_bytes;
  }
  if (!vertex) fail_at(path, line_number, "the PLY header has no vertex element");
  for (std::size_t c = 0; c < 3; ++c) {
    const std::string_view axis = std::array{"x", "y", "z"}[c];
    const auto coordinate = vertex->find(axis);
    if (!coordinate) fail_at(path, vertex->line, "the vertex element has no property " + std::string(axis));
    const PlyProperty& property = vertex->properties[*coordinate];
    if (property.length) fail_at(path, property.line, "the vertex property " + quoted(axis) + " is a list (a number is needed)");
    header.coordinates[c] = *coordinate;
  }
  if (!face || face->count == 0) fail_at(path, line_number, "the PLY file has no faces");
  auto corners = face->find("vertex_indices");
  if (!corners) corners = face->find("vertex_index");
  if (!corners || !face->properties[*corners].length) fail_at(path, face->line, "the face element has no vertex_indices list");
  const PlyProperty& indices = face->properties[*corners];
  if (indices.value.is_float) fail_at(path, indices.line, "vertex indices of type " + quoted(indices.value.name) + " (an integer type is needed)");
  header.corners = *corners;
  const std::size_t body = content.size() - header.body_start;
  if (least_bytes > body) {
    fail_at(path, line_number, "the header declares more than the file holds (" + std::to_string(vertex->count) + " vertices and " +
                                   std::to_string(face->count) + " faces need at least " + std::to_string(least_bytes) +
                                   " bytes; " + std::to_string(body) + " follow the header)");
  }
  return header;
}

// Where a value is, for a message.
struct Place {
  const PlyElement& element;
  std::size_t item;
  const PlyProperty& property;
};

std::string describe(const Place& place) {
  return "element " + quoted(place.element.name) + " item " + std::to_string(place.item) + " property " + quoted(place.property.name);
}

// An ASCII body: values separated by whitespace; a problem names the line of the last value read.
class AsciiBody {
 public:
  AsciiBody(const std::filesystem::path& path, std::string_view text, std::size_t first_line)
      : path_(path), text_(text), first_line_(first_line) {}

  double number(const PlyType&, const Place& place) {
    const auto token = next(place);
    const auto value = parse_double(token);
    if (!value) fail(quoted(token) + " is not a number (" + describe(place) + ")");
    return *value;
  }

  long long integer(const PlyType& type, const Place& place) {
    const auto token = next(place);
    const auto value = parse_integer(token);
    if (!value) fail(quoted(token) + " is not an integer (" + describe(place) + ", of type " + quoted(type.name) + ")");
    return *value;
  }

  // The most values of any type the rest of the body could hold: a digit and a separator each.
  std::size_t values_left(const PlyType&) const { return (text_.size() - position_ + 1) / 2; }

  // Lines are counted only here, for a message, by the rule every text reader shares.
  [[noreturn]] void fail(const std::string& problem) const {
    std::size_t line = first_line_;
    for_each_raw_line(text_, [&](std::size_t number, std::string_view text) {
      if (static_cast<std::size_t>(text.data() - text_.data()) <= token_start_) line = first_line_ + number - 1;
    });
    fail_at(path_, line, problem);
  }

 private:
  std::string_view next(const Place& place) {
    while (position_ < text_.size() && is_separator(text_[position_])) ++position_;
    if (position_ == text_.size()) fail("the file ends before " + describe(place) + " (the header declares " + std::to_string(place.element.count) + ")");
    token_start_ = position_;
    while (position_ < text_.size() && !is_separator(text_[position_])) ++position_;
    return text_.substr(token_start_, position_ - token_start_);
  }

  static bool is_separator(char c) { return is_blank(c) || c == '\n' || c == '\r'; }

  const std::filesystem::path& path_;
  std::string_view text_;
  std::size_t first_line_;
  std::size_t position_ = 0;
  std::size_t token_start_ = 0;  // where the last value read begins
};

// A binary body: each value in its type's size and the file's byte order; a problem names the
// byte offset in the file.
class BinaryBody {
 public:
  BinaryBody(const std::filesystem::path& path, std::string_view bytes, std::size_t offset, bool big_endian)
      : path_(path), bytes_(bytes), offset_(offset), big_endian_(big_endian) {}

  double number(const PlyType& type, const Place& place) {
    const auto raw = take(type, place);
    if (type.is_float) {
      if (type.size == 4) return std::bit_cast<float>(static_cast<std::uint32_t>(raw));
      return std::bit_cast<double>(raw);
    }
    return static_cast<double>(as_integer(type, raw));
  }

  long long integer(const PlyType& type, const Place& place) { return as_integer(type, take(type, place)); }

  std::size_t values_left(const PlyType& type) const { return (bytes_.size() - position_) / type.size; }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(path_.string() + ": byte " + std::to_string(offset_ + start_) + ": " + problem);
  }

 private:
  std::uint64_t take(const PlyType& type, const Place& place) {
    start_ = position_;
    if (bytes_.size() - position_ < type.size) {
      fail("the file ends before " + describe(place) + " (the header declares " + std::to_string(place.element.count) + ")");
    }
    std::uint64_t value = 0;
    for (std::size_t b = 0; b < type.size; ++b) {
      const std::size_t significance = big_endian_ ? type.size - 1 - b : b;
      value |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes_[position_ + b])) << (8 * significance);
    }
    position_ += type.size;
    return value;
  }

  static long long as_integer(const PlyType& type, std::uint64_t raw) {
    const unsigned bits = static_cast<unsigned>(8 * type.size);
    if (type.is_signed && (raw >> (bits - 1)) != 0) return static_cast<long long>(raw) - (1LL << bits);
    return static_cast<long long>(raw);
  }

  const std::filesystem::path& path_;
  std::string_view bytes_;
  std::size_t offset_;
  bool big_endian_;
  std::size_t position_ = 0;
  std::size_t start_ = 0;  // where the last value began
};

struct PlyContent {
  std::vector<std::array<double, 3>> points;
  Polygons polygons;
};

// Reads the elements in header order until the vertices and the faces are read; what follows
// them is not looked at.
template <class Body>
PlyContent read_body(const PlyHeader& header, Body& body) {
  PlyContent content;
  const std::size_t vertex_count = header.elements[header.vertex].count;
  content.points.reserve(vertex_count);  // the header check bounded it by the body's size
  std::vector<int> corners;
  std::size_t wanted = 2;
  for (std::size_t e = 0; e < header.elements.size() && wanted > 0; ++e) {
    const PlyElement& element = header.elements[e];
    const bool is_vertex = e == header.vertex;
    const bool is_face = e == header.face;
    // Nothing to read, however many items it declares (the bytes-left check bounds every other count).
    if (element.properties.empty()) continue;
    if (is_face) {
      // Room for triangles, as many as the rest of the body can hold: growing these by doubling
      // at 3.3 million faces wrote twice the pages, and a fresh page is slow on some hosts.
      const std::size_t most_corners = std::min(3 * element.count, body.values_left(element.properties[header.corners].value));
      content.polygons.corners.reserve(most_corners);
      content.polygons.start.reserve(most_corners / 3 + 1);
    }
    for (std::size_t item = 0; item < element.count; ++item) {
      std::array<double, 3> point{};
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        const Place place{element, item, property};
        if (!property.length) {
          const double value = body.number(property.value, place);
          for (std::size_t c = 0; c < 3; ++c) {
            // A float property holds a float, however many digits an ASCII file wrote.
            if (is_vertex && p == header.coordinates[c]) {
              point[c] = property.value.is_float && property.value.size == 4 ? static_cast<double>(static_cast<float>(value)) : value;
            }
          }
          continue;
        }
        const long long length = body.integer(*property.length, place);
        if (length < 0 || length > property.length->largest()) {
          body.fail(describe(place) + " has a list of length " + std::to_string(length) + " (its length type " +
                    quoted(property.length->name) + " holds 0 to " + std::to_string(property.length->largest()) + ")");
        }
        const auto size = static_cast<std::size_t>(length);
        if (size > body.values_left(property.value)) {
          body.fail(describe(place) + " has a list of length " + std::to_string(size) + ", more than the rest of the file holds");
        }
        if (!is_face || p != header.corners) {
          for (std::size_t k = 0; k < size; ++k) body.number(property.value, place);
          continue;
        }
        if (size < 3) body.fail("face " + std::to_string(item) + " has " + std::to_string(size) + " vertices (at least 3 are needed)");
        corners.resize(size);
        for (std::size_t k = 0; k < size; ++k) {
          const long long index = body.integer(property.value, place);
          if (index < 0 || index >= static_cast<long long>(vertex_count)) {
            body.fail("face " + std::to_string(item) + " corner " + std::to_string(k) + " has vertex index " + std::to_string(index) +
                      ", out of range (" + std::to_string(vertex_count) + " vertices)");
          }
          corners[k] = static_cast<int>(index);
        }
        content.polygons.add(corners.data(), corners.size());
      }
      if (is_vertex) content.points.push_back(point);
    }
    if (is_vertex || is_face) --wanted;
  }
  return content;
}

}  // namespace

Mesh parse_ply(const std::filesystem::path& path, std::string_view content) {
  const PlyHeader header = parse_ply_header(path, content);
  const std::string_view data = content.substr(header.body_start);
  PlyContent read;
  if (header.encoding == PlyEncoding::Ascii) {
    AsciiBody body(path, data, header.body_line);
    read = read_body(header, body);
  } else {
    BinaryBody body(path, data, header.body_start, header.encoding == PlyEncoding::BigEndian);
    read = read_body(header, body);
  }
  return mesh_of(read.points, read.polygons, path.string());
}

}  // namespace hdeform::detail

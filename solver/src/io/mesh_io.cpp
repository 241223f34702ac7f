#include "hdeform/mesh_io.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <climits>
#include <optional>

#include <tbb/parallel_for.h>

#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"
#include "hdeform/trace.h"
#include "obj_pieces.h"
#include "polygons.h"
#include "text_scan.h"

namespace hdeform {
namespace {

using detail::fail_at;
using detail::Polygons;
using detail::triangulate;
using detail::quoted;

// "v", "v/vt", "v//vn" or "v/vt/vn": the vertex part, checked to be a non-zero integer; the
// other parts are ignored but must be empty or integers.
long long face_vertex_reference(const std::filesystem::path& path, std::size_t line, std::string_view token) {
  std::array<std::string_view, 3> parts;
  std::size_t part_count = 0;
  for (std::size_t begin = 0;;) {
    const std::size_t slash = token.find('/', begin);
    if (part_count == parts.size()) fail_at(path, line, "face vertex " + quoted(token) + " has more than three '/' parts");
    parts[part_count++] = token.substr(begin, slash == std::string_view::npos ? std::string_view::npos : slash - begin);
    if (slash == std::string_view::npos) break;
    begin = slash + 1;
  }
  const auto index = detail::parse_integer(parts[0]);
  if (!index) fail_at(path, line, "face vertex " + quoted(token) + " is not an index");
  for (std::size_t k = 1; k < part_count; ++k) {
    if (!parts[k].empty() && !detail::parse_integer(parts[k])) {
      fail_at(path, line, "face vertex " + quoted(token) + ": " + quoted(parts[k]) + " is not a texture or normal index");
    }
  }
  if (*index == 0) fail_at(path, line, "face vertex index 0 (OBJ indices start at 1)");
  return *index;
}

void append_number(std::string& out, double value) {
  std::array<char, 32> buffer;
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  out.append(buffer.data(), result.ptr);
}

}  // namespace

namespace {

// What the lines of an OBJ (or of a piece of one) define.
struct ObjContent {
  std::vector<double> coordinates;
  Polygons polygons;
  long long vertex_count = 0;
  // Positive indices may refer forward: those are checked against the final count afterwards.
  struct ForwardReference {
    std::size_t line;
    long long index;
  };
  std::vector<ForwardReference> forward_references;
  // A piece after the first does not know the vertices before it: its relative indices are
  // resolved against its own count (so may be negative) and listed here for the caller.
  bool knows_earlier_vertices = true;
  std::vector<std::size_t> relative_corners;
};

void parse_obj_line(const std::filesystem::path& path, std::size_t line, std::string_view text, std::vector<std::string_view>& tokens,
                    ObjContent& content) {
  detail::split_tokens(text, tokens);
  if (tokens.empty()) return;
  const std::string_view keyword = tokens[0];
  if (keyword == "v") {
    if (tokens.size() < 4) fail_at(path, line, "vertex needs 3 coordinates, found " + std::to_string(tokens.size() - 1));
    if (tokens.size() > 8) {
      fail_at(path, line, "vertex has " + std::to_string(tokens.size() - 1) + " values (at most 7: x y z, then w or r g b [a])");
    }
    for (std::size_t k = 1; k < tokens.size(); ++k) {
      const auto value = detail::parse_double(tokens[k]);
      if (!value) fail_at(path, line, "vertex coordinate " + quoted(tokens[k]) + " is not a number");
      if (k <= 3 && !std::isfinite(*value)) fail_at(path, line, "non-finite vertex coordinate " + quoted(tokens[k]));
      if (k <= 3) content.coordinates.push_back(*value);
    }
    if (++content.vertex_count > INT_MAX) fail_at(path, line, "more than " + std::to_string(INT_MAX) + " vertices");
  } else if (keyword == "f") {
    if (tokens.size() < 4) fail_at(path, line, "face needs at least 3 vertices, found " + std::to_string(tokens.size() - 1));
    for (std::size_t k = 1; k < tokens.size(); ++k) {
      const long long index = face_vertex_reference(path, line, tokens[k]);
      const long long reach = content.knows_earlier_vertices ? content.vertex_count : INT_MAX;
      if (index < 0 && -index > reach) {
        fail_at(path, line, "relative face index " + std::to_string(index) + " reaches before the first vertex (" +
                                std::to_string(content.vertex_count) + " defined so far)");
      }
      if (index > INT_MAX) {
        fail_at(path, line, "face index " + std::to_string(index) + " out of range (at most " + std::to_string(INT_MAX) + " vertices)");
      }
      // Only an index beyond the vertices so far can be beyond the last one.
      if (index > content.vertex_count) content.forward_references.push_back({line, index});
      if (index < 0 && !content.knows_earlier_vertices) content.relative_corners.push_back(content.polygons.corners.size());
      content.polygons.corners.push_back(static_cast<int>(index > 0 ? index - 1 : content.vertex_count + index));
    }
    content.polygons.start.push_back(content.polygons.corners.size());
  }
}

Mesh obj_mesh(const std::filesystem::path& path, ObjContent& content) {
  if (content.polygons.count() == 0) {
    throw InputError(path.string() + (content.vertex_count == 0 ? ": empty: no vertices and no triangles" : ": no triangles (the file has no faces)"));
  }
  Mesh mesh;
  mesh.positions = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(
      content.coordinates.data(), static_cast<Eigen::Index>(content.vertex_count), 3);
  triangulate(content.polygons, mesh.positions, mesh.triangles);
  // The arrays just built are what every algorithm trusts; check them, not the text.
  validate_mesh(mesh, path.string());
  return mesh;
}

Mesh parse_obj_in_one_pass(const std::filesystem::path& path, std::string_view content) {
  detail::reject_binary(path, content);
  ObjContent parsed;
  std::vector<std::string_view> tokens;
  detail::for_each_line(content, [&](std::size_t line, std::string_view text) { parse_obj_line(path, line, text, tokens, parsed); });
  for (const auto& reference : parsed.forward_references) {
    if (reference.index > parsed.vertex_count) {
      fail_at(path, reference.line, "face index " + std::to_string(reference.index) + " out of range (the file has " +
                                        std::to_string(parsed.vertex_count) + " vertices)");
    }
  }
  return obj_mesh(path, parsed);
}

// Where a piece may end: after a line feed whose line does not continue on the next (a
// backslash at its end, outside a comment), at or after `from`.
std::size_t piece_end(std::string_view content, std::size_t from) {
  while (true) {
    const std::size_t feed = content.find('\n', from);
    if (feed == std::string_view::npos) return content.size();
    std::size_t line_end = feed;
    if (line_end > 0 && content[line_end - 1] == '\r') --line_end;
    std::size_t line_start = line_end;
    while (line_start > 0 && content[line_start - 1] != '\n' && content[line_start - 1] != '\r') --line_start;
    std::string_view line = content.substr(line_start, line_end - line_start);
    if (const auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    line = detail::trim_trailing_blanks(line);
    // A byte-order mark is skipped at the start of the content only: no piece may start with one.
    if ((line.empty() || line.back() != '\\') && !content.substr(feed + 1).starts_with("\xEF\xBB\xBF")) return feed + 1;
    from = feed + 1;
  }
}

// The pieces parsed in parallel and joined; nullopt when anything is wrong with any of them (the
// one-pass reader then names the first problem exactly as it always does).
std::optional<ObjContent> parse_obj_pieces(const std::filesystem::path& path, std::string_view content, std::size_t piece_bytes) {
  std::vector<std::string_view> pieces;
  for (std::size_t start = 0; start < content.size();) {
    const std::size_t end = piece_end(content, std::min(content.size(), start + piece_bytes) - 1);
    pieces.push_back(content.substr(start, end - start));
    start = end;
  }
  std::vector<ObjContent> parsed(pieces.size());
  std::atomic<bool> failed = false;
  tbb::parallel_for(std::size_t{0}, pieces.size(), [&](std::size_t p) {
    if (failed.load(std::memory_order_relaxed)) return;
    parsed[p].knows_earlier_vertices = p == 0;
    std::vector<std::string_view> tokens;
    try {
      detail::reject_binary(path, pieces[p]);
      detail::for_each_line(pieces[p], [&](std::size_t line, std::string_view text) { parse_obj_line(path, line, text, tokens, parsed[p]); });
    } catch (const InputError&) {
      failed = true;
    }
  });
  if (failed) return std::nullopt;

  ObjContent joined;
  std::vector<long long> first_vertex(pieces.size());
  std::vector<std::size_t> first_corner(pieces.size()), first_polygon(pieces.size());
  std::size_t corners = 0, polygons = 0;
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    first_vertex[p] = joined.vertex_count;
    first_corner[p] = corners;
    first_polygon[p] = polygons;
    joined.vertex_count += parsed[p].vertex_count;
    corners += parsed[p].polygons.corners.size();
    polygons += parsed[p].polygons.count();
  }
  if (joined.vertex_count > INT_MAX) return std::nullopt;
  joined.coordinates.resize(static_cast<std::size_t>(joined.vertex_count) * 3);
  joined.polygons.corners.resize(corners);
  joined.polygons.start.resize(polygons + 1, 0);
  tbb::parallel_for(std::size_t{0}, pieces.size(), [&](std::size_t p) {
    const ObjContent& piece = parsed[p];
    std::copy(piece.coordinates.begin(), piece.coordinates.end(), joined.coordinates.begin() + static_cast<std::ptrdiff_t>(first_vertex[p] * 3));
    int* corner = joined.polygons.corners.data() + first_corner[p];
    std::copy(piece.polygons.corners.begin(), piece.polygons.corners.end(), corner);
    for (const std::size_t relative : piece.relative_corners) {
      const long long resolved = first_vertex[p] + corner[relative];
      if (resolved < 0) failed = true;
      corner[relative] = static_cast<int>(resolved);
    }
    for (std::size_t q = 1; q <= piece.polygons.count(); ++q) joined.polygons.start[first_polygon[p] + q] = first_corner[p] + piece.polygons.start[q];
    for (const auto& reference : piece.forward_references) {
      if (reference.index > joined.vertex_count) failed = true;
    }
  });
  if (failed) return std::nullopt;
  return joined;
}

constexpr std::size_t kPieceBytes = std::size_t{1} << 20;

}  // namespace

namespace detail {

std::optional<Mesh> try_parse_obj_in_pieces(const std::filesystem::path& path, std::string_view content, std::size_t piece_bytes) {
  auto parsed = parse_obj_pieces(path, content, std::max<std::size_t>(piece_bytes, 1));
  if (!parsed) return std::nullopt;
  return obj_mesh(path, *parsed);
}

}  // namespace detail

Mesh parse_obj(const std::filesystem::path& path, std::string_view content) {
  // Large files are parsed in pieces on every core; below two pieces there is nothing to share.
  if (content.size() >= 2 * kPieceBytes) {
    if (auto mesh = detail::try_parse_obj_in_pieces(path, content, kPieceBytes)) return std::move(*mesh);
  }
  return parse_obj_in_one_pass(path, content);
}

Mesh read_obj(const std::filesystem::path& path) {
  const trace::Scope traced("read OBJ", "set-up");
  return parse_obj(path, detail::read_text_file(path));
}

void write_obj(const std::filesystem::path& path, const Mesh& mesh) {
  std::string text;
  text.reserve(static_cast<std::size_t>(mesh.vertex_count() * 64 + mesh.triangle_count() * 32));
  text += "# written by hdeform\n";
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    text += 'v';
    for (int c = 0; c < 3; ++c) {
      text += ' ';
      append_number(text, mesh.positions(v, c));
    }
    text += '\n';
  }
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    text += 'f';
    for (int c = 0; c < 3; ++c) {
      text += ' ';
      text += std::to_string(mesh.triangles(t, c) + 1);
    }
    text += '\n';
  }
  write_file_atomically(path, [&](std::ostream& out) { out.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

}  // namespace hdeform

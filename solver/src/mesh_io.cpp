#include "hdeform/mesh_io.h"

#include <array>
#include <charconv>
#include <climits>

#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"
#include "hdeform/trace.h"
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

Mesh parse_obj(const std::filesystem::path& path, std::string_view content) {
  detail::reject_binary(path, content);
  std::vector<double> coordinates;
  Polygons polygons;
  // Positive indices may refer forward: they are checked against the final count afterwards.
  struct ForwardReference {
    std::size_t line;
    long long index;
  };
  std::vector<ForwardReference> forward_references;
  long long vertex_count = 0;
  std::vector<std::string_view> tokens;

  detail::for_each_line(content, [&](std::size_t line, std::string_view text) {
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
        if (k <= 3) coordinates.push_back(*value);
      }
      if (++vertex_count > INT_MAX) fail_at(path, line, "more than " + std::to_string(INT_MAX) + " vertices");
    } else if (keyword == "f") {
      if (tokens.size() < 4) fail_at(path, line, "face needs at least 3 vertices, found " + std::to_string(tokens.size() - 1));
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const long long index = face_vertex_reference(path, line, tokens[k]);
        if (index < 0 && -index > vertex_count) {
          fail_at(path, line, "relative face index " + std::to_string(index) + " reaches before the first vertex (" +
                                  std::to_string(vertex_count) + " defined so far)");
        }
        if (index > INT_MAX) {
          fail_at(path, line, "face index " + std::to_string(index) + " out of range (at most " + std::to_string(INT_MAX) + " vertices)");
        }
        if (index > 0) forward_references.push_back({line, index});
        polygons.corners.push_back(static_cast<int>(index > 0 ? index - 1 : vertex_count + index));
      }
      polygons.start.push_back(polygons.corners.size());
    }
  });
  for (const auto& reference : forward_references) {
    if (reference.index > vertex_count) {
      fail_at(path, reference.line, "face index " + std::to_string(reference.index) + " out of range (the file has " +
                                        std::to_string(vertex_count) + " vertices)");
    }
  }
  if (polygons.count() == 0) {
    throw InputError(path.string() + (vertex_count == 0 ? ": empty: no vertices and no triangles" : ": no triangles (the file has no faces)"));
  }

  Mesh mesh;
  mesh.positions = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(
      coordinates.data(), static_cast<Eigen::Index>(vertex_count), 3);
  triangulate(polygons, mesh.positions, mesh.triangles);
  // The arrays just built are what every algorithm trusts; check them, not the text.
  validate_mesh(mesh, path.string());
  return mesh;
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

#include "hdeform/mesh_io.h"

#ifndef TINYOBJLOADER_USE_DOUBLE
#define TINYOBJLOADER_USE_DOUBLE  // must match the tinyobjloader_double library
#endif
#include <tiny_obj_loader.h>

#include <array>
#include <charconv>
#include <sstream>

#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"
#include "text_scan.h"

namespace hdeform {
namespace {

using detail::fail_at;
using detail::quoted;

// tinyobjloader turns unparsable numbers into zeros and drops faces with bad indices without
// saying where. This pass runs first and rejects exactly those inputs with file and line, so
// tinyobjloader only ever sees faces it reads correctly. It also keeps the coordinates: parsed
// with from_chars they are correctly rounded, where tinyobjloader's parser may be off in the
// last bits.
std::vector<double> scan_obj_vertices(const std::filesystem::path& path, std::string_view content) {
  std::vector<double> coordinates;
  detail::reject_binary(path, content);
  long long vertex_count = 0;
  std::size_t face_count = 0;
  std::vector<std::string_view> tokens;
  // Positive indices may refer forward; check them against the final count afterwards.
  struct ForwardReference { std::size_t line; long long index; };
  std::vector<ForwardReference> forward_references;

  detail::for_each_line(content, [&](std::size_t line, std::string_view text) {
    detail::split_tokens(text, tokens);
    if (tokens.empty()) return;
    const std::string_view keyword = tokens[0];
    if (keyword == "v") {
      if (tokens.size() < 4) fail_at(path, line, "vertex needs 3 coordinates, found " + std::to_string(tokens.size() - 1));
      for (std::size_t k = 1; k < tokens.size() && k <= 7; ++k) {
        const auto value = detail::parse_double(tokens[k]);
        if (!value) fail_at(path, line, "vertex coordinate " + quoted(tokens[k]) + " is not a number");
        if (k <= 3 && !std::isfinite(*value)) fail_at(path, line, "non-finite vertex coordinate " + quoted(tokens[k]));
        if (k <= 3) coordinates.push_back(*value);
      }
      ++vertex_count;
    } else if (keyword == "f") {
      if (tokens.size() < 4) fail_at(path, line, "face needs at least 3 vertices, found " + std::to_string(tokens.size() - 1));
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const std::string_view reference = tokens[k].substr(0, tokens[k].find('/'));
        const auto index = detail::parse_integer(reference);
        if (!index) fail_at(path, line, "face vertex " + quoted(tokens[k]) + " is not an index");
        if (*index == 0) fail_at(path, line, "face vertex index 0 (OBJ indices start at 1)");
        if (*index < 0 && -*index > vertex_count) {
          fail_at(path, line, "relative face index " + std::to_string(*index) + " reaches before the first vertex (" +
                                  std::to_string(vertex_count) + " defined so far)");
        }
        if (*index > 0) forward_references.push_back({line, *index});
      }
      ++face_count;
    }
  });
  for (const auto& reference : forward_references) {
    if (reference.index > vertex_count) {
      fail_at(path, reference.line, "face index " + std::to_string(reference.index) + " out of range (the file has " +
                                        std::to_string(vertex_count) + " vertices)");
    }
  }
  if (face_count == 0) {
    throw InputError(path.string() + (vertex_count == 0 ? ": empty: no vertices and no triangles" : ": no triangles (the file has no faces)"));
  }
  return coordinates;
}

void append_number(std::string& out, double value) {
  std::array<char, 32> buffer;
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  out.append(buffer.data(), result.ptr);
}

}  // namespace

Mesh read_obj(const std::filesystem::path& path) {
  const std::string content = detail::read_text_file(path);
  const std::vector<double> coordinates = scan_obj_vertices(path, content);

  tinyobj::attrib_t attributes;
  std::vector<tinyobj::shape_t> shapes;
  std::string warnings;
  std::string errors;
  std::istringstream stream(content);
  if (!tinyobj::LoadObj(&attributes, &shapes, nullptr, &warnings, &errors, &stream, nullptr, true, false)) {
    throw InputError(path.string() + ": " + (errors.empty() ? std::string("not a readable OBJ file") : errors));
  }

  Mesh mesh;
  const auto vertex_count = static_cast<Eigen::Index>(coordinates.size() / 3);
  mesh.positions = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(coordinates.data(), vertex_count, 3);
  std::size_t corner_count = 0;
  for (const auto& shape : shapes) corner_count += shape.mesh.indices.size();
  mesh.triangles.resize(static_cast<Eigen::Index>(corner_count / 3), 3);
  Eigen::Index t = 0;
  for (const auto& shape : shapes) {
    const auto& corners = shape.mesh.indices;
    for (std::size_t k = 0; k + 2 < corners.size(); k += 3, ++t) {
      for (int c = 0; c < 3; ++c) mesh.triangles(t, c) = corners[k + static_cast<std::size_t>(c)].vertex_index;
    }
  }
  if (mesh.triangle_count() == 0) throw InputError(path.string() + ": no triangles");
  return mesh;
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

// STL through OpenMesh's reader (OFF and PLY have readers of our own, mesh_readers.h), into plain
// arrays: an importer of our own keeps every vertex in file order and every face as written
// (OpenMesh's own meshes would drop or split faces at non-manifold edges), and the faces become
// triangles by the OBJ reader's rule.
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <iostream>
#include <mutex>
#include <sstream>

#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/trace.h"
#include "mesh_readers.h"
#include "polygons.h"
#include "text_scan.h"

namespace hdeform {
namespace {

namespace om = OpenMesh;
using om::FaceHandle;
using om::HalfedgeHandle;
using om::VertexHandle;

class ArrayImporter final : public om::IO::BaseImporter {
 public:
  std::vector<std::array<double, 3>> points;
  detail::Polygons polygons;
  std::string problem;  // the first bad face, if any

  VertexHandle add_vertex(const om::Vec3f& p) override { return add_vertex(om::Vec3d(p[0], p[1], p[2])); }
  VertexHandle add_vertex(const om::Vec3d& p) override {
    points.push_back({p[0], p[1], p[2]});
    return VertexHandle(static_cast<int>(points.size() - 1));
  }
  VertexHandle add_vertex() override { return add_vertex(om::Vec3d(0, 0, 0)); }
  void set_point(VertexHandle v, const om::Vec3f& p) override {
    if (v.idx() >= 0 && static_cast<std::size_t>(v.idx()) < points.size()) points[static_cast<std::size_t>(v.idx())] = {p[0], p[1], p[2]};
  }
  FaceHandle add_face(const VHandles& corners) override {
    const std::size_t face = polygons.count();
    if (!problem.empty()) return FaceHandle(static_cast<int>(face));
    if (corners.size() < 3) {
      problem = "face " + std::to_string(face) + " has " + std::to_string(corners.size()) + " vertices (at least 3 are needed)";
      return FaceHandle();
    }
    std::vector<int> indices;
    indices.reserve(corners.size());
    for (std::size_t k = 0; k < corners.size(); ++k) {
      const int index = corners[k].idx();
      if (index < 0 || static_cast<std::size_t>(index) >= points.size()) {
        problem = "face " + std::to_string(face) + " corner " + std::to_string(k) + " has vertex index " +
                  std::to_string(index) + ", out of range (" + std::to_string(points.size()) + " vertices)";
        return FaceHandle();
      }
      indices.push_back(index);
    }
    polygons.add(indices.data(), indices.size());
    return FaceHandle(static_cast<int>(face));
  }
  size_t n_vertices() const override { return points.size(); }
  size_t n_faces() const override { return polygons.count(); }
  size_t n_edges() const override { return 0; }

  // Topology, normals, colours, texture coordinates and status: not part of a Mesh.
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override { return HalfedgeHandle(); }
  FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<om::Vec2f>&) override {}
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<om::Vec3f>&) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_normal(VertexHandle, const om::Vec3f&) override {}
  void set_normal(VertexHandle, const om::Vec3d&) override {}
  void set_color(VertexHandle, const om::Vec3uc&) override {}
  void set_color(VertexHandle, const om::Vec4uc&) override {}
  void set_color(VertexHandle, const om::Vec3f&) override {}
  void set_color(VertexHandle, const om::Vec4f&) override {}
  void set_texcoord(VertexHandle, const om::Vec2f&) override {}
  void set_status(VertexHandle, const om::Attributes::StatusInfo&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const om::Vec2f&) override {}
  void set_texcoord(VertexHandle, const om::Vec3f&) override {}
  void set_texcoord(HalfedgeHandle, const om::Vec3f&) override {}
  void set_status(HalfedgeHandle, const om::Attributes::StatusInfo&) override {}
  void set_color(om::EdgeHandle, const om::Vec3uc&) override {}
  void set_color(om::EdgeHandle, const om::Vec4uc&) override {}
  void set_color(om::EdgeHandle, const om::Vec3f&) override {}
  void set_color(om::EdgeHandle, const om::Vec4f&) override {}
  void set_status(om::EdgeHandle, const om::Attributes::StatusInfo&) override {}
  void set_normal(FaceHandle, const om::Vec3f&) override {}
  void set_normal(FaceHandle, const om::Vec3d&) override {}
  void set_color(FaceHandle, const om::Vec3uc&) override {}
  void set_color(FaceHandle, const om::Vec4uc&) override {}
  void set_color(FaceHandle, const om::Vec3f&) override {}
  void set_color(FaceHandle, const om::Vec4f&) override {}
  void set_status(FaceHandle, const om::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}
};

// Binary STL: an 80-byte header, a 32-bit triangle count, 50 bytes per triangle. Anything else
// is read as ASCII ("solid ... endsolid").
bool is_binary_stl(std::string_view content) {
  if (content.size() < 84) return false;
  std::uint32_t count = 0;
  std::memcpy(&count, content.data() + 80, sizeof count);
  return content.size() == 84 + 50 * static_cast<std::uint64_t>(count);
}

// OpenMesh reports through its own error stream and answers only true or false; the stream is
// caught for the message. It is global, so one read at a time. Connected once for good: each
// connect allocates a wrapper that disconnect never frees. The stream is never destroyed, since
// OpenMesh's own stream, a static of its library, may flush into it during exit.
std::mutex openmesh_stream_mutex;

std::ostringstream& openmesh_errors() {
  static std::ostringstream* const caught = [] {
    auto* stream = new std::ostringstream;
    ::omlog().disable();
    ::omout().disable();
    ::omerr().disconnect(std::cerr);
    ::omerr().connect(*stream);
    return stream;
  }();
  return *caught;
}

// The last line OpenMesh wrote, without its "[STLReader] : " style prefix.
std::string openmesh_message(const std::string& stream) {
  std::string line;
  std::istringstream lines(stream);
  for (std::string next; std::getline(lines, next);) {
    if (next.find_first_not_of(" \t\r") != std::string::npos) line = next;
  }
  const auto colon = line.find("] : ");
  if (line.starts_with('[') && colon != std::string::npos) line = line.substr(colon + 4);
  while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
  return line;
}

Mesh parse_stl(const std::filesystem::path& path, std::string_view content) {
  const std::string name = path.string();
  om::IO::Options options;
  if (is_binary_stl(content)) {
    options += om::IO::Options::Binary;
  } else {
    const auto first = content.find_first_not_of(" \t\r\n");
    if (first == std::string_view::npos || content.substr(first, 5) != "solid") {
      throw InputError(name + ": neither ASCII STL (it does not start with \"solid\") nor binary STL (an 84-byte header "
                       "and 50 bytes per triangle)");
    }
  }
  ArrayImporter importer;
  bool read = false;
  std::string stream;
  {
    const std::lock_guard lock(openmesh_stream_mutex);
    std::ostringstream& caught = openmesh_errors();
    caught.str({});
    caught.clear();
    std::istringstream in{std::string(content), std::ios::binary};
    try {
      read = om::IO::IOManager().read(in, ".stl", importer, options);
    } catch (const std::exception& error) {
      caught << error.what() << '\n';
    }
    ::omerr().flush();
    stream = caught.str();
  }
  if (!importer.problem.empty()) throw InputError(name + ": " + importer.problem);
  if (!read) {
    const auto message = openmesh_message(stream);
    throw InputError(name + ": not a readable STL file" + (message.empty() ? "" : " (" + message + ")"));
  }
  if (importer.polygons.count() == 0) throw InputError(name + ": the STL file has no faces");
  return detail::mesh_of(importer.points, importer.polygons, name);
}

void append_bytes(std::string& out, const void* data, std::size_t size) { out.append(static_cast<const char*>(data), size); }

}  // namespace

std::optional<MeshFormat> mesh_format_of(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".obj") return MeshFormat::Obj;
  if (extension == ".ply") return MeshFormat::Ply;
  if (extension == ".off") return MeshFormat::Off;
  if (extension == ".stl") return MeshFormat::Stl;
  return std::nullopt;
}

Mesh parse_mesh(const std::filesystem::path& path, std::string_view content) {
  const auto format = mesh_format_of(path);
  if (!format) {
    throw InputError(path.string() + ": unknown mesh format " + detail::quoted(path.extension().string()) + " (" +
                     std::string(kReadableMeshFormats) + ")");
  }
  if (*format == MeshFormat::Obj) return parse_obj(path, content);
  if (content.empty()) throw InputError(path.string() + ": an empty file");
  if (*format == MeshFormat::Off) return detail::parse_off(path, content);
  if (*format == MeshFormat::Ply) return detail::parse_ply(path, content);
  return parse_stl(path, content);
}

Mesh read_mesh(const std::filesystem::path& path) {
  const auto format = mesh_format_of(path);
  if (format == MeshFormat::Obj) return read_obj(path);
  const trace::Scope traced("read mesh", "set-up");
  if (!format) return parse_mesh(path, {});
  return parse_mesh(path, detail::read_text_file(path));
}

void write_ply(const std::filesystem::path& path, const Mesh& mesh) {
  validate_mesh(mesh, path.string());
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment written by hdeform\nelement vertex " +
                    std::to_string(mesh.vertex_count()) + "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
                    std::to_string(mesh.triangle_count()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  out.reserve(out.size() + static_cast<std::size_t>(mesh.vertex_count() * 24 + mesh.triangle_count() * 13));
  static_assert(std::endian::native == std::endian::little, "PLY is written little-endian");
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    for (int c = 0; c < 3; ++c) {
      const double value = mesh.positions(v, c);
      append_bytes(out, &value, sizeof value);
    }
  }
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    const unsigned char corners = 3;
    append_bytes(out, &corners, 1);
    for (int c = 0; c < 3; ++c) {
      const std::int32_t index = mesh.triangles(t, c);
      append_bytes(out, &index, sizeof index);
    }
  }
  write_file_atomically(path, [&](std::ostream& stream) { stream.write(out.data(), static_cast<std::streamsize>(out.size())); });
}

void write_mesh(const std::filesystem::path& path, const Mesh& mesh) {
  const auto format = mesh_format_of(path);
  if (format == MeshFormat::Obj) return write_obj(path, mesh);
  if (format == MeshFormat::Ply) return write_ply(path, mesh);
  throw InputError(path.string() + ": meshes are written as .obj or .ply, not " + detail::quoted(path.extension().string()));
}

}  // namespace hdeform

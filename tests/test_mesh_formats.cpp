// PLY, OFF and STL: each format written here by an independent writer, then read by the library
// (PLY and OFF by its own readers, STL by OpenMesh's into hdeform's arrays) and compared with the
// OBJ reader on the same mesh.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <type_traits>

#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

// The cactus with every coordinate rounded to single precision, so that every format (STL and a
// PLY float property hold floats) holds it exactly.
Mesh float_exact_cactus() {
  Mesh mesh = make_shape(ShapeKind::Cactus, 12).mesh;
  mesh.positions = mesh.positions.cast<float>().cast<double>();
  return mesh;
}

std::string decimal(double value, int digits = 9) {  // 9: a float exactly, 17: a double
  std::array<char, 40> buffer;
  std::snprintf(buffer.data(), buffer.size(), "%.*g", digits, value);
  return buffer.data();
}

std::string ascii_ply(const Mesh& mesh) {
  std::string text = "ply\nformat ascii 1.0\ncomment with a property the reader must skip\nelement vertex " +
                     std::to_string(mesh.vertex_count()) +
                     "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar quality\nelement face " +
                     std::to_string(mesh.triangle_count()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    text += decimal(mesh.positions(v, 0)) + " " + decimal(mesh.positions(v, 1)) + " " + decimal(mesh.positions(v, 2)) + " 7\n";
  }
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    text += "3 " + std::to_string(mesh.triangles(t, 0)) + " " + std::to_string(mesh.triangles(t, 1)) + " " + std::to_string(mesh.triangles(t, 2)) + "\n";
  }
  return text;
}

template <class T>
void put_big_endian(std::string& out, T value) {
  std::array<char, sizeof(T)> bytes;
  std::memcpy(bytes.data(), &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::little) std::reverse(bytes.begin(), bytes.end());
  out.append(bytes.data(), bytes.size());
}

template <class T>
void put_little_endian(std::string& out, T value) {
  std::array<char, sizeof(T)> bytes;
  std::memcpy(bytes.data(), &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes.begin(), bytes.end());
  out.append(bytes.data(), bytes.size());
}

std::string big_endian_ply(const Mesh& mesh) {
  std::string out = "ply\nformat binary_big_endian 1.0\nelement vertex " + std::to_string(mesh.vertex_count()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(mesh.triangle_count()) +
                    "\nproperty list uchar int vertex_indices\nend_header\n";
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    for (int c = 0; c < 3; ++c) put_big_endian(out, static_cast<float>(mesh.positions(v, c)));
  }
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    out += '\3';
    for (int c = 0; c < 3; ++c) put_big_endian(out, static_cast<std::int32_t>(mesh.triangles(t, c)));
  }
  return out;
}

std::string off_text(const Mesh& mesh) {
  std::string text = "OFF\n# a comment\n" + std::to_string(mesh.vertex_count()) + " " + std::to_string(mesh.triangle_count()) + " 0\n";
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {  // OFF is read in double precision
    text += decimal(mesh.positions(v, 0), 17) + " " + decimal(mesh.positions(v, 1), 17) + " " + decimal(mesh.positions(v, 2), 17) + "\n";
  }
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    text += "3 " + std::to_string(mesh.triangles(t, 0)) + " " + std::to_string(mesh.triangles(t, 1)) + " " + std::to_string(mesh.triangles(t, 2)) + "\n";
  }
  return text;
}

std::string binary_stl(const Mesh& mesh) {
  std::string out(80, ' ');
  put_little_endian(out, static_cast<std::uint32_t>(mesh.triangle_count()));
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    for (int c = 0; c < 3; ++c) put_little_endian(out, 0.0f);  // the normal, which readers ignore
    for (int corner = 0; corner < 3; ++corner) {
      for (int c = 0; c < 3; ++c) put_little_endian(out, static_cast<float>(mesh.positions(mesh.triangles(t, corner), c)));
    }
    put_little_endian(out, std::uint16_t{0});
  }
  return out;
}

std::string ascii_stl(const Mesh& mesh) {
  std::string text = "solid cactus\n";
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    text += "  facet normal 0 0 0\n    outer loop\n";
    for (int corner = 0; corner < 3; ++corner) {
      const auto v = mesh.triangles(t, corner);
      text += "      vertex " + decimal(mesh.positions(v, 0)) + " " + decimal(mesh.positions(v, 1)) + " " + decimal(mesh.positions(v, 2)) + "\n";
    }
    text += "    endloop\n  endfacet\n";
  }
  return text + "endsolid cactus\n";
}

// What an STL reader must build: corners at one position are one vertex, numbered by first
// occurrence, triangle 0's corners first.
Mesh merged_in_first_occurrence_order(const Mesh& mesh) {
  std::map<std::array<double, 3>, int> index_of;
  std::vector<std::array<double, 3>> points;
  Mesh merged;
  merged.triangles.resize(mesh.triangle_count(), 3);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    for (int corner = 0; corner < 3; ++corner) {
      const auto v = mesh.triangles(t, corner);
      const std::array<double, 3> point{mesh.positions(v, 0), mesh.positions(v, 1), mesh.positions(v, 2)};
      const auto [it, inserted] = index_of.emplace(point, static_cast<int>(points.size()));
      if (inserted) points.push_back(point);
      merged.triangles(t, corner) = it->second;
    }
  }
  merged.positions.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t v = 0; v < points.size(); ++v) {
    for (int c = 0; c < 3; ++c) merged.positions(static_cast<Eigen::Index>(v), c) = points[v][static_cast<std::size_t>(c)];
  }
  return merged;
}

void expect_same_mesh(const Mesh& actual, const Mesh& expected) {
  ASSERT_EQ(actual.vertex_count(), expected.vertex_count());
  ASSERT_EQ(actual.triangle_count(), expected.triangle_count());
  EXPECT_EQ(actual.positions, expected.positions);
  EXPECT_EQ(actual.triangles, expected.triangles);
}

TEST(MeshFormats, PlyAndOffAgreeWithTheObjReaderVertexForVertex) {
  const test::TempDir dir;
  const Mesh mesh = float_exact_cactus();
  write_obj(dir.file("cactus.obj"), mesh);
  const Mesh from_obj = read_mesh(dir.file("cactus.obj"));
  expect_same_mesh(from_obj, mesh);
  dir.write("ascii.ply", ascii_ply(mesh));
  dir.write("big-endian.PLY", big_endian_ply(mesh));
  dir.write("cactus.off", off_text(mesh));
  for (const char* name : {"ascii.ply", "big-endian.PLY", "cactus.off"}) {
    SCOPED_TRACE(name);
    expect_same_mesh(read_mesh(dir.file(name)), from_obj);
  }
}

TEST(MeshFormats, StlCornersBecomeVerticesInTheOrderTheyFirstOccur) {
  const test::TempDir dir;
  const Mesh mesh = float_exact_cactus();
  const Mesh expected = merged_in_first_occurrence_order(mesh);
  ASSERT_EQ(expected.vertex_count(), mesh.vertex_count());  // the cactus has no two vertices at one place
  dir.write("binary.stl", binary_stl(mesh));
  dir.write("ascii.stl", ascii_stl(mesh));
  for (const char* name : {"binary.stl", "ascii.stl"}) {
    SCOPED_TRACE(name);
    const Mesh read = read_mesh(dir.file(name));
    expect_same_mesh(read, expected);
    // The same surface: every triangle's corners where the original's were.
    for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
      for (int corner = 0; corner < 3; ++corner) {
        ASSERT_EQ(read.positions.row(read.triangles(t, corner)), mesh.positions.row(mesh.triangles(t, corner)));
      }
    }
  }
}

TEST(MeshFormats, WrittenPlyReadsBackExactly) {
  const test::TempDir dir;
  const Mesh mesh = make_shape(ShapeKind::Bar, 12).mesh;
  write_mesh(dir.file("bar.ply"), mesh);
  const Mesh back = read_mesh(dir.file("bar.ply"));
  EXPECT_EQ(back.triangles, mesh.triangles);
  // Written as double properties, read as doubles: every bit comes back.
  EXPECT_EQ(back.positions, mesh.positions);
  write_mesh(dir.file("bar.obj"), mesh);
  EXPECT_EQ(read_mesh(dir.file("bar.obj")).positions, mesh.positions);
  EXPECT_THROW(write_mesh(dir.file("bar.stl"), mesh), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir.file("bar.stl")));
}

TEST(MeshFormats, PolygonsAreTriangulatedAsInObjAndNonManifoldFacesKept) {
  const test::TempDir dir;
  // A quad, a pentagon, and three triangles on the edge 0-1 (non-manifold); vertex 7 unreferenced.
  const std::string points = "0 0 0\n1 0 0\n1 1 0\n0 1.25 0\n2 0 0\n2 1 0\n0.5 0.5 1\n9 9 9\n";
  dir.write("faces.off", "OFF\n8 5 0\n" + points + "4 0 1 2 3\n5 1 4 5 2 6\n3 0 1 6\n3 1 0 5\n3 0 1 4\n");
  dir.write("faces.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1.25 0\nv 2 0 0\nv 2 1 0\nv 0.5 0.5 1\nv 9 9 9\n"
                         "f 1 2 3 4\nf 2 5 6 3 7\nf 1 2 7\nf 2 1 6\nf 1 2 5\n");
  const Mesh from_off = read_mesh(dir.file("faces.off"));
  EXPECT_EQ(from_off.vertex_count(), 8);
  EXPECT_EQ(from_off.triangle_count(), 2 + 3 + 3);
  expect_same_mesh(from_off, read_mesh(dir.file("faces.obj")));
}

// Expects read_mesh to throw InputError starting with the file's path (and perhaps a line) and containing `fragment`.
void expect_refused(const test::TempDir& dir, const std::string& name, const std::string& content, const std::string& fragment) {
  SCOPED_TRACE(name);
  dir.write(name, content);
  try {
    read_mesh(dir.file(name));
    ADD_FAILURE() << "no error for " << name;
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_TRUE(message.starts_with(dir.file(name).string() + ":")) << message;
    EXPECT_NE(message.find(fragment), std::string::npos) << "'" << fragment << "' not in: " << message;
  }
}

// The OFF header's words may come from lines joined by a backslash, whose buffer the next
// continuation grows (the fuzzer found the header read from freed memory).
TEST(MeshFormats, AnOffHeaderSpreadOverContinuedLinesIsKept) {
  // The first joined line short (kept inside the string) and long (on the heap, freed when the
  // second one outgrows it).
  for (const std::size_t blanks : {0, 40}) {
    const std::string content =
        "OFF" + std::string(blanks, ' ') + "\\\n\n3 \\\n" + std::string(200, ' ') + "1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const Mesh mesh = parse_mesh("continued.off", content);
    ASSERT_EQ(mesh.vertex_count(), 3) << blanks;
    ASSERT_EQ(mesh.triangle_count(), 1) << blanks;
    EXPECT_EQ(mesh.positions(1, 0), 1.0);
    EXPECT_EQ(mesh.triangles(0, 2), 2);
  }
}

TEST(MeshFormats, MalformedFilesNameTheFileAndTheProblem) {
  const test::TempDir dir;
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  expect_refused(dir, "index.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", "face 0 corner 2 has vertex index 5, out of range (3 vertices)");
  expect_refused(dir, "negative.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "face 0 corner 1 has vertex index -1");
  expect_refused(dir, "two.ply", header + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "face 0 has 2 vertices (at least 3 are needed)");
  Mesh with_nan = make_shape(ShapeKind::Bar, 8).mesh;
  with_nan.positions(1, 0) = std::numeric_limits<double>::quiet_NaN();
  expect_refused(dir, "nan.ply", big_endian_ply(with_nan), "vertex 1 has a non-finite coordinate");
  expect_refused(dir, "header.ply", "ply\nformat ascii 1.0\nelement vertex three\n", ":3: element 'vertex' has count 'three', not a count");
  expect_refused(dir, "format.ply", "ply\nformat text 1.0\nend_header\n", ":2: unknown PLY format");
  expect_refused(dir, "noz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nelement face 1\n"
                 "property list uchar int vertex_indices\nend_header\n0 0\n3 0 0 0\n", ":3: the vertex element has no property z");
  expect_refused(dir, "not.ply", "solid no\n", ":1: not a PLY file");
  std::string truncated = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                          "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  truncated += std::string(20, '\0');
  expect_refused(dir, "truncated.ply", truncated, ":9: the header declares more than the file holds");
  expect_refused(dir, "huge.ply", header.substr(0, header.find("element vertex 3")) + "element vertex 2000000000\n" +
                 header.substr(header.find("property float x")) + "0 0 0\n", "the header declares more than the file holds");
  expect_refused(dir, "body.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "the file ends before");
  expect_refused(dir, "empty.ply", "", "an empty file");
  expect_refused(dir, "index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "face 0 corner 2 has vertex index 3, out of range");
  expect_refused(dir, "faceless.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", ":2: the OFF file has no faces");
  expect_refused(dir, "header.off", "OFX\n3 1 0\n", ":1: not an OFF file");
  expect_refused(dir, "counts.off", "OFF\n# counts next\n3 one 0\n", ":3: 'one' is not a count");
  expect_refused(dir, "huge.off", "OFF\n900000000 1 0\n0 0 0\n", ":2: the header declares more than the file holds");
  expect_refused(dir, "binary.off", "OFF BINARY\n\1\2\3", "binary");
  // A face count beyond what its line holds (OpenMesh would read that many, 9e10 here: the fuzzer's find).
  expect_refused(dir, "face-count.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n90000000000 0 1 2\n",
                 ":7: face 1 size '90000000000' is not a count");
  expect_refused(dir, "face-short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", ":6: face 0 declares 4 vertices but its line holds 3 numbers");
  expect_refused(dir, "vertex-short.off", "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n", ":4: vertex 1 needs 3 coordinates, found 2");
  expect_refused(dir, "ends-early.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", ":6: the file ends after 3 of 3 vertices and 1 of 2 faces");
  expect_refused(dir, "garbage.stl", "\x01\x02 not an STL", "neither ASCII STL");
  expect_refused(dir, "empty.stl", "", "an empty file");
  expect_refused(dir, "points.xyz", "0 0 0\n", "unknown mesh format '.xyz' (.obj, .ply, .off or .stl)");
}

// A PLY body written value by value, as text or as little-endian bytes.
struct PlyBody {
  bool binary = false;
  std::string out;

  template <class T>
  void put(T value) {
    if (binary) {
      put_little_endian(out, value);
    } else {
      out += std::is_floating_point_v<T> ? decimal(static_cast<double>(value)) : std::to_string(value);
      out += ' ';
    }
  }
  void end_line() {
    if (!binary) out += '\n';
  }
};

// Lists in every element, of every length type, before and after the ones a mesh is made of; an
// obj_info line holding header words; an element after the faces that is never read. OpenMesh
// read a vertex's list as one value and took the obj_info words for a header line.
std::string ply_with_lists_everywhere(const Mesh& mesh, bool binary) {
  std::string text = std::string("ply\nformat ") + (binary ? "binary_little_endian" : "ascii") +
                     " 1.0\ncomment lists everywhere\nobj_info element face 99 property list int int vertex_indices\n"
                     "element material 2\nproperty list int float ambient\nproperty uchar id\n"
                     "element vertex " + std::to_string(mesh.vertex_count()) +
                     "\nproperty float x\nproperty list ushort float normal_list\nproperty float y\nproperty float z\nproperty double quality\n"
                     "element face " + std::to_string(mesh.triangle_count()) +
                     "\nproperty uchar red\nproperty list int uint vertex_indices\nproperty list uchar float texcoord\n"
                     "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
  PlyBody body{binary, {}};
  body.put(std::int32_t{3});
  for (const float value : {0.1f, 0.2f, 0.3f}) body.put(value);
  body.put(std::uint8_t{7});
  body.end_line();
  body.put(std::int32_t{0});
  body.put(std::uint8_t{8});
  body.end_line();
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    body.put(static_cast<float>(mesh.positions(v, 0)));
    body.put(std::uint16_t{2});
    body.put(1.5f);
    body.put(-2.0f);
    body.put(static_cast<float>(mesh.positions(v, 1)));
    body.put(static_cast<float>(mesh.positions(v, 2)));
    body.put(0.25);
    body.end_line();
  }
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    body.put(std::uint8_t{200});
    body.put(std::int32_t{3});
    if (t % 2 == 1) body.end_line();  // a face split over lines reads the same
    for (int c = 0; c < 3; ++c) body.put(static_cast<std::uint32_t>(mesh.triangles(t, c)));
    body.put(std::uint8_t{6});
    for (int k = 0; k < 6; ++k) body.put(0.5f * static_cast<float>(k));
    body.end_line();
  }
  text += body.out;
  return text + (binary ? std::string(8, '\xff') : std::string("never read\n"));
}

TEST(MeshFormats, PlyListsOfAnyLengthTypeAreReadPastInEveryElement) {
  const test::TempDir dir;
  const Mesh mesh = float_exact_cactus();
  for (const bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    dir.write("lists.ply", ply_with_lists_everywhere(mesh, binary));
    expect_same_mesh(read_mesh(dir.file("lists.ply")), mesh);
  }
}

TEST(MeshFormats, PlyElementsInAnyOrderAndCoordinatesInTheirDeclaredPrecision) {
  const test::TempDir dir;
  // An element without properties holds nothing, however many items it declares.
  dir.write("order.ply", "ply\nformat ascii 1.0\nelement nothing 2000000000\nelement face 1\nproperty list uchar int vertex_index\n"
                         "element vertex 3\nproperty float x\nproperty double y\nproperty float z\nend_header\n"
                         "3 2 0 1\n0.1 0.1 0.1\n1 0 0\n0 1 0\n");
  const Mesh mesh = read_mesh(dir.file("order.ply"));
  ASSERT_EQ(mesh.vertex_count(), 3);
  ASSERT_EQ(mesh.triangle_count(), 1);
  EXPECT_EQ(mesh.triangles.row(0), Eigen::RowVector3i(2, 0, 1));
  // A float property holds the float nearest what was written; a double the double.
  EXPECT_EQ(mesh.positions(0, 0), static_cast<double>(0.1f));
  EXPECT_EQ(mesh.positions(0, 1), 0.1);
  EXPECT_EQ(mesh.positions(0, 2), static_cast<double>(0.1f));
  EXPECT_NE(0.1, static_cast<double>(0.1f));
}

// Every list length is checked against its type and against what the rest of the file could
// hold before anything is reserved (OpenMesh took a face's size from whatever token it met and
// allocated until the fuzzer stopped it at 2 GB).
TEST(MeshFormats, PlyListsLongerThanTheFileAreRefusedBeforeAnythingIsReserved) {
  const test::TempDir dir;
  auto ascii = [](const std::string& list_type, const std::string& face) {
    return "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\n"
           "property list " + list_type + " vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n" + face + "\n";
  };
  expect_refused(dir, "uint.ply", ascii("uint int", "4000000000 0 1 2"),
                 ":13: element 'face' item 0 property 'vertex_indices' has a list of length 4000000000, more than the rest of the file holds");
  expect_refused(dir, "uchar.ply", ascii("uchar int", "300 0 1 2"), ":13: element 'face' item 0 property 'vertex_indices' has a list of "
                                                                     "length 300 (its length type 'uchar' holds 0 to 255)");
  expect_refused(dir, "negative.ply", ascii("int int", "-3 0 1 2"), "has a list of length -3 (its length type 'int' holds 0 to 2147483647)");
  expect_refused(dir, "exponent.ply", ascii("uchar int", "3e0 0 1 2"), ":13: '3e0' is not an integer (element 'face' item 0 property 'vertex_indices'");
  expect_refused(dir, "float-length.ply", ascii("float int", "3 0 1 2"), ":8: a list length of type 'float' (an integer type is needed)");
  expect_refused(dir, "float-index.ply", ascii("uchar float", "3 0 1 2"), ":8: vertex indices of type 'float' (an integer type is needed)");
  expect_refused(dir, "word.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                  "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",
                 ":11: 'zero' is not a number (element 'vertex' item 1 property 'y')");
  // Lines end at LF, CRLF or a lone CR in the body as in every text reader.
  for (const std::string end : {"\r\n", "\r"}) {
    std::string body = "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n";
    for (std::size_t at = body.find('\n'); at != std::string::npos; at = body.find('\n', at + end.size())) body.replace(at, 1, end);
    expect_refused(dir, "word-" + std::to_string(end.size()) + ".ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                   "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" + body, ":11: 'zero' is not a number");
  }
  expect_refused(dir, "twice.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nelement vertex 3\n", ":5: a second element 'vertex' (the first is on line 3)");
  expect_refused(dir, "list-x.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty list uchar float x\nproperty float y\nproperty float z\n"
                                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n",
                 ":4: the vertex property 'x' is a list (a number is needed)");

  std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                       "element face 1\nproperty list uint int vertex_indices\nproperty uchar red\nend_header\n";
  const std::size_t body = binary.size();
  for (int k = 0; k < 9; ++k) put_little_endian(binary, static_cast<float>(k));
  put_little_endian(binary, std::uint32_t{0xffffffff});
  for (int k = 0; k < 3; ++k) put_little_endian(binary, std::int32_t{k});
  expect_refused(dir, "binary.ply", binary, ": byte " + std::to_string(body + 36) + ": element 'face' item 0 property 'vertex_indices' has a "
                                           "list of length 4294967295, more than the rest of the file holds");
  binary.replace(body + 36, 4, std::string("\3\0\0\0", 4));  // a length that fits, and then no byte for 'red'
  expect_refused(dir, "short.ply", binary, ": byte " + std::to_string(body + 52) + ": the file ends before element 'face' item 0 property 'red' (the header declares 1)");
  // A signed length type: the byte 0xff is -1, not 255.
  std::string signed_length = "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                              "element face 1\nproperty list char short vertex_indices\nend_header\n";
  for (int k = 0; k < 9; ++k) put_big_endian(signed_length, static_cast<float>(k));
  signed_length += '\xff';
  for (int k = 0; k < 3; ++k) put_big_endian(signed_length, static_cast<std::int16_t>(k));
  expect_refused(dir, "signed.ply", signed_length, "has a list of length -1 (its length type 'char' holds 0 to 127)");
  // And a signed index below zero is out of range, not a large unsigned one.
  signed_length.replace(signed_length.size() - 7, 1, "\3");
  signed_length.replace(signed_length.size() - 2, 2, "\xff\xfe");
  expect_refused(dir, "signed-index.ply", signed_length, "face 0 corner 2 has vertex index -2, out of range (3 vertices)");
}

TEST(MeshFormats, TheBenchmarkMeshesReadAlikeInEveryFormat) {
  HDEFORM_REQUIRE_SHARED_MESHES();
  const test::TempDir dir;
  Mesh mesh = read_mesh(test::shared_meshes() / "deformation-benchmark" / "cactus.obj");
  mesh.positions = mesh.positions.cast<float>().cast<double>();
  dir.write("cactus.off", off_text(mesh));
  dir.write("cactus.ply", big_endian_ply(mesh));
  expect_same_mesh(read_mesh(dir.file("cactus.off")), mesh);
  expect_same_mesh(read_mesh(dir.file("cactus.ply")), mesh);
}

}  // namespace
}  // namespace hdeform

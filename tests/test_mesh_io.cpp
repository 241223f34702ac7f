#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>

#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

// Expects read_obj to throw InputError whose message contains every given fragment.
void expect_read_error(const test::TempDir& dir, const std::string& content, const std::vector<std::string>& fragments) {
  dir.write("bad.obj", content);
  try {
    read_obj(dir.file("bad.obj"));
    ADD_FAILURE() << "no error for:\n" << content;
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("bad.obj"), std::string::npos) << message;
    for (const auto& fragment : fragments) EXPECT_NE(message.find(fragment), std::string::npos) << "'" << fragment << "' not in: " << message;
  }
}

TEST(MeshIo, RoundTripIsExact) {
  const test::TempDir dir;
  const Mesh mesh = make_shape(ShapeKind::Cactus, 16).mesh;
  write_obj(dir.file("cactus.obj"), mesh);
  const Mesh back = read_obj(dir.file("cactus.obj"));
  ASSERT_EQ(back.vertex_count(), mesh.vertex_count());
  ASSERT_EQ(back.triangle_count(), mesh.triangle_count());
  EXPECT_EQ(back.triangles, mesh.triangles);
  EXPECT_EQ(back.positions, mesh.positions);  // shortest round-trip decimals are exact
}

TEST(MeshIo, TriangulatesPolygonsAndIgnoresAttributes) {
  const test::TempDir dir;
  dir.write("quad.obj",
            "# a quad and two triangles, with normals, texture coordinates and a material\n"
            "mtllib missing.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0.5 0\nv 7 7 7\n"
            "vt 0 0\nvn 0 0 1\nusemtl none\ns 1\n"
            "f 1/1/1 2/1/1 3/1/1 4/1/1\nf 2//1 5//1 3//1\nf -6 -5 -3\n");
  const Mesh mesh = read_obj(dir.file("quad.obj"));
  EXPECT_EQ(mesh.vertex_count(), 6);  // the unreferenced vertex 6 is kept, order unchanged
  EXPECT_EQ(mesh.triangle_count(), 4);
  EXPECT_DOUBLE_EQ(mesh.positions(5, 2), 7.0);
  EXPECT_EQ(mesh.triangles.row(3), Eigen::RowVector3i(0, 1, 3));  // relative indices resolved
  EXPECT_LE(mesh.triangles.maxCoeff(), 4);
}

TEST(MeshIo, MalformedFilesGiveTheirErrors) {
  const test::TempDir dir;
  expect_read_error(dir, "", {"empty: no vertices and no triangles"});
  expect_read_error(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\n", {"no triangles"});
  expect_read_error(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", {":4:", "out of range", "3 vertices"});
  expect_read_error(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", {":4:", "index 0"});
  expect_read_error(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", {":4:", "before the first vertex"});
  expect_read_error(dir, "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", {":2:", "non-finite"});
  expect_read_error(dir, "v 0 0 0\nv 1 inf 0\nv 0 1 0\nf 1 2 3\n", {":2:", "non-finite"});
  expect_read_error(dir, "v 0 0 0\nv 1 1e999 0\nv 0 1 0\nf 1 2 3\n", {":2:", "non-finite"});
  expect_read_error(dir, "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", {":2:", "3 coordinates"});
  expect_read_error(dir, "v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n", {":2:", "not a number"});
  expect_read_error(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", {":4:", "at least 3"});
  expect_read_error(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 a 3\n", {":4:", "not an index"});
  expect_read_error(dir, std::string("v 0 0 0\n\x89PNG\x01\x02\x00garbage", 22), {":2:", "binary"});
}

TEST(MeshIo, UnreadableFileNamesTheFile) {
  try {
    read_obj("/nonexistent/dir/mesh.obj");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/dir/mesh.obj"), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("cannot open"), std::string::npos);
  }
}

TEST(MeshIo, WriteIsAtomicAndLeavesNoTemporaryFiles) {
  const test::TempDir dir;
  const Mesh mesh = make_shape(ShapeKind::Sphere, 8).mesh;
  write_obj(dir.file("a.obj"), mesh);
  write_obj(dir.file("a.obj"), mesh);  // replaces
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1);
  EXPECT_THROW(write_obj(dir.file("missing-dir/a.obj"), mesh), InputError);
}

TEST(MeshIo, TemporariesOfKilledWritersAreRemovedOthersKept) {
  const test::TempDir dir;
  const pid_t finished = fork();  // a process that has ended: its pid names no writer
  if (finished == 0) _exit(0);
  ASSERT_GT(finished, 0);
  waitpid(finished, nullptr, 0);
  const auto mine = std::to_string(getpid());
  const auto parent = std::to_string(getppid());
  const std::vector<std::string> kept{"a.obj", ".a.obj.tmp." + mine + ".1", ".a.obj.tmp." + parent + ".2", ".b.obj.tmp." + std::to_string(finished) + ".3",
                                      ".a.obj.tmp.notapid.4", ".a.obj.tmp.99999999999999999999.6"};
  for (const auto& name : kept) dir.write(name, "v 0 0 0\n");
  dir.write(".a.obj.tmp." + std::to_string(finished) + ".5", "v 0 0");  // killed mid-write
  EXPECT_EQ(remove_abandoned_temporaries(dir.file("a.obj")), 1u);
  std::vector<std::string> left;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) left.push_back(entry.path().filename().string());
  std::sort(left.begin(), left.end());
  std::vector<std::string> expected = kept;
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(left, expected);
}

}  // namespace
}  // namespace hdeform

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "io/obj_pieces.h"
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

// Reads OBJ text, or returns the refusal's message.
struct ReadResult {
  std::optional<Mesh> mesh;
  std::string error;
};
ReadResult read_text(const test::TempDir& dir, const std::string& content) {
  dir.write("in.obj", content);
  try {
    return {read_obj(dir.file("in.obj")), ""};
  } catch (const InputError& error) {
    return {std::nullopt, error.what()};
  }
}

// Issue 15, the file that once read past the mesh: a lone CR was a line end for one reading of the file and
// a blank for another, so indices were checked against 3 vertices and the mesh had 4.
TEST(MeshIo, LoneCarriageReturnEndsALineAndIndicesMatchTheMeshBuilt) {
  const test::TempDir dir;
  const auto read = read_text(dir, std::string("-\rv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf -1 -2 -3\n"));
  ASSERT_TRUE(read.mesh) << read.error;
  EXPECT_EQ(read.mesh->vertex_count(), 4);
  ASSERT_EQ(read.mesh->triangle_count(), 1);
  EXPECT_EQ(read.mesh->triangles.row(0), Eigen::RowVector3i(3, 2, 1));
  EXPECT_NO_THROW(validate_mesh(*read.mesh));

  // The input libFuzzer found (base64 in issue 15): five vertices, one face (-1 02 -3).
  const std::string found("\x89\n\r\n-\rv 0 0 0\nv 1 0 0\nv 0 1 0 0\nv 0 1 0\nv 1 1 0\nf -1 02 -3\n 0 0 0\nv01 0 0 1 1 1\n");
  const auto fuzzed = read_text(dir, found);
  ASSERT_TRUE(fuzzed.mesh) << fuzzed.error;
  EXPECT_EQ(fuzzed.mesh->vertex_count(), 5);
  ASSERT_EQ(fuzzed.mesh->triangle_count(), 1);
  EXPECT_EQ(fuzzed.mesh->triangles.row(0), Eigen::RowVector3i(4, 1, 2));
  const auto weights = cotangent_weights(*fuzzed.mesh);  // where the overflow was
  EXPECT_EQ(weights.kind.size(), 1u);
}

// The same mesh written every way a text file can end its lines and lay out its blanks.
TEST(MeshIo, LineEndsBlanksMarksAndContinuationsReadAsTheLfOriginal) {
  const test::TempDir dir;
  const std::string original =
      "# a quad, a triangle and a relative face\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0.5 0.25\n"
      "f 1 2 3 4\nf 2 5 3\nf -5 -4 -1\n";
  const auto reference = read_text(dir, original);
  ASSERT_TRUE(reference.mesh) << reference.error;
  ASSERT_EQ(reference.mesh->triangle_count(), 4);
  const auto replace_all = [](std::string text, const std::string& from, const std::string& to) {
    for (std::size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size()) text.replace(at, from.size(), to);
    return text;
  };
  std::string mixed;  // LF, CRLF and CR in turn
  int line = 0;
  for (const char c : original) {
    if (c != '\n') {
      mixed += c;
      continue;
    }
    mixed += std::array<const char*, 3>{"\n", "\r\n", "\r"}[static_cast<std::size_t>(line++ % 3)];
  }
  const std::vector<std::pair<std::string, std::string>> variants = {
      {"CRLF", replace_all(original, "\n", "\r\n")},
      {"lone CR", replace_all(original, "\n", "\r")},
      {"mixed line ends", mixed},
      {"byte-order mark", "\xEF\xBB\xBF" + original},
      {"tabs", replace_all(original, " ", "\t")},
      {"form feeds and vertical tabs", replace_all(replace_all(original, "v ", "v\f"), "f ", "f\v ")},
      {"trailing blanks and blank lines", replace_all(original, "\n", " \t\n\n")},
      {"no final line end", original.substr(0, original.size() - 1)},
      {"backslash continuations", replace_all(replace_all(original, "f 1 2 ", "f 1 \\\n2 \\\r\n"), "v 2 0.5", "v \\\n 2 0.5")},
      {"comments after values", replace_all(original, "\n", " # note\n")},
  };
  for (const auto& [name, content] : variants) {
    const auto read = read_text(dir, content);
    ASSERT_TRUE(read.mesh) << name << ": " << read.error;
    EXPECT_EQ(read.mesh->positions, reference.mesh->positions) << name;
    EXPECT_EQ(read.mesh->triangles, reference.mesh->triangles) << name;
  }
}

// The parallel path cuts the text into pieces at line ends and joins what they define. Cut every
// way small pieces allow, each text reads as in one pass: the same arrays, bit for bit, or (for a
// text with a problem) no mesh, so that the one pass names the problem.
TEST(MeshIo, PiecesReadInParallelGiveTheOnePassResult) {
  const test::TempDir dir;
  std::vector<std::string> texts = {
      // relative indices that reach back into earlier pieces, forward references, a quad, a pentagon
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n# a comment\nv 2 0.5 0.25\nf -4 -1 -3\nf 2 6 3\nv 3 1 0\nv 3 2 0\nf 1 2 7 8 4\nf 5 6 -1\n",
      "\xEF\xBB\xBFv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n",  // a byte-order mark, CRLF
      "v 0 0 0\rv 1 0 0\rv 0 1 0\rf -3 -2 -1\r",                // lone CR only: one piece
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 \\\n 2 \\\r\n 3\n\\\nf 3 2 1 # \\\n",  // continuations
      "v 0 0 0\nv 1 0 0\nv 0 1 0\n\xEF\xBB\xBFv 9 9 9\nf 1 2 3\n",  // a mark inside is no mark
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n",  // reaches before the first vertex
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",   // out of range
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
      "v 0 0 0\nv 1 0 0\nv 0 1 0\n",            // no faces
      std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\x01\n", 35),
  };
  // And a real mesh with relative faces: every face written as negative indices.
  const Mesh cactus = make_shape(ShapeKind::Cactus, 12).mesh;
  std::ostringstream written;
  for (Eigen::Index v = 0; v < cactus.vertex_count(); ++v) {
    written << "v " << cactus.positions(v, 0) << ' ' << cactus.positions(v, 1) << ' ' << cactus.positions(v, 2) << '\n';
    for (Eigen::Index t = 0; t < cactus.triangle_count(); ++t) {
      if (cactus.triangles.row(t).maxCoeff() != v) continue;
      written << 'f';
      for (int c = 0; c < 3; ++c) written << ' ' << cactus.triangles(t, c) - v - 1;
      written << '\n';
    }
  }
  const std::string relative = written.str();
  texts.push_back(relative);
  for (std::size_t i = 0; i < texts.size(); ++i) {
    const auto whole = read_text(dir, texts[i]);
    for (const std::size_t piece_bytes : {1, 2, 3, 7, 16, 61, 1000}) {
      SCOPED_TRACE("text " + std::to_string(i) + ", pieces of " + std::to_string(piece_bytes) + " bytes");
      std::optional<Mesh> pieces;
      std::string error;
      try {
        pieces = detail::try_parse_obj_in_pieces("in.obj", texts[i], piece_bytes);
      } catch (const InputError& thrown) {
        error = thrown.what();
      }
      if (whole.mesh) {
        ASSERT_TRUE(pieces) << error;
        EXPECT_EQ(pieces->positions, whole.mesh->positions);
        EXPECT_EQ(pieces->triangles, whole.mesh->triangles);
      } else {
        EXPECT_FALSE(pieces);
        // Only the joined arrays' problems (no faces here) are named by the pieces, as the one pass names them.
        if (!error.empty()) {
          EXPECT_EQ(error.substr(error.find(':')), whole.error.substr(whole.error.find(':'))) << error;
        }
      }
    }
  }
  EXPECT_EQ(read_text(dir, relative).mesh->triangles.rows(), cactus.triangle_count());
}

TEST(MeshIo, LineNumbersCountEveryKindOfLineEnd) {
  const test::TempDir dir;
  // Line 4 is bad whichever line ends lead up to it, and a continued line is named by its start.
  for (const std::string end : {"\n", "\r\n", "\r"}) {
    const auto read = read_text(dir, "v 0 0 0" + end + "v 1 0 0" + end + "v 0 1 0" + end + "f 1 2 9" + end);
    EXPECT_NE(read.error.find(":4: face index 9 out of range"), std::string::npos) << read.error;
  }
  const auto continued = read_text(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 \\\n2 \\\n x\n");
  EXPECT_NE(continued.error.find(":4: face vertex 'x' is not an index"), std::string::npos) << continued.error;
  const auto binary = read_text(dir, std::string("v 0 0 0\rv 1 0 0\r\x01", 17));
  EXPECT_NE(binary.error.find(":3: binary data"), std::string::npos) << binary.error;
}

TEST(MeshIo, FaceVertexFormsAndTheirErrors) {
  const test::TempDir dir;
  const auto read = read_text(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1 2/1/1 3//1\nf 1/ 2// 3/1/\n");
  ASSERT_TRUE(read.mesh) << read.error;
  EXPECT_EQ(read.mesh->triangle_count(), 2);
  EXPECT_NE(read_text(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x 2 3\n").error.find(":4: face vertex '1/x': 'x' is not a texture or normal index"),
            std::string::npos);
  EXPECT_NE(read_text(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n").error.find(":4: face vertex '1/1/1/1' has more than three"),
            std::string::npos);
  EXPECT_NE(read_text(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 1 2 3 4 5 6 7 8\n").error.find(":5: vertex has 8 values"),
            std::string::npos);
  EXPECT_NE(read_text(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999\n").error.find(":4: face index 99999999999 out of range"),
            std::string::npos);
  // Extra vertex values (w, or a colour) are read and dropped.
  const auto coloured = read_text(dir, "v 0 0 0 1 0 0\nv 1 0 0 0.5\nv 0 1 0 0 0 1 1\nf 1 2 3\n");
  ASSERT_TRUE(coloured.mesh) << coloured.error;
  EXPECT_EQ(coloured.mesh->positions.row(2), Eigen::RowVector3d(0, 1, 0));
}

TEST(MeshIo, QuadsSplitAlongTheShorterDiagonalLargerPolygonsIntoAFan) {
  const test::TempDir dir;
  // The quad's shorter diagonal joins 0-based corners 1 and 3 (10 against 17); listed from its
  // last corner, it is split along the same diagonal.
  const auto read = read_text(dir, "v 0 0 0\nv 3 0 0\nv 4 1 0\nv 0 1 0\nv 9 9 9\nf 1 2 3 4\nf 4 1 2 3\nf 1 2 3 4 5\n");
  ASSERT_TRUE(read.mesh) << read.error;
  ASSERT_EQ(read.mesh->triangle_count(), 7);
  const Eigen::MatrixXi expected = (Eigen::MatrixXi(7, 3) << 0, 1, 3, 1, 2, 3,
                                    3, 0, 1, 3, 1, 2,
                                    0, 1, 2, 0, 2, 3, 0, 3, 4)
                                       .finished();
  EXPECT_EQ(read.mesh->triangles, expected);
}

TEST(MeshIo, ValidateMeshNamesTheElement) {
  Mesh mesh = make_shape(ShapeKind::Sphere, 8).mesh;
  EXPECT_NO_THROW(validate_mesh(mesh));
  const auto message = [](const Mesh& bad) {
    try {
      validate_mesh(bad, "thing.obj");
    } catch (const InputError& error) {
      return std::string(error.what());
    }
    return std::string("(accepted)");
  };
  Mesh out_of_range = mesh;
  out_of_range.triangles(5, 1) = static_cast<int>(mesh.vertex_count());
  EXPECT_EQ(message(out_of_range), "thing.obj: triangle 5 corner 1 has vertex index " + std::to_string(mesh.vertex_count()) +
                                       ", out of range (the mesh has " + std::to_string(mesh.vertex_count()) + " vertices)");
  Mesh negative = mesh;
  negative.triangles(0, 2) = -1;
  EXPECT_NE(message(negative).find("triangle 0 corner 2 has vertex index -1"), std::string::npos);
  Mesh not_a_number = mesh;
  not_a_number.positions(3, 1) = std::nan("");
  EXPECT_EQ(message(not_a_number), "thing.obj: vertex 3 has a non-finite coordinate y = nan");
  Mesh wide = mesh;
  wide.positions.conservativeResize(Eigen::NoChange, 4);
  EXPECT_NE(message(wide).find("positions must have 3 columns"), std::string::npos);
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

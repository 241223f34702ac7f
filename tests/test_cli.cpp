// The hdeform executable as a user meets it: exit codes, messages, outputs.
#include <nlohmann/json.hpp>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "hdeform/deformer.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

test::CommandOutcome run(const test::TempDir& dir, const std::string& arguments) {
  return test::run_command(std::string(HDEFORM_EXECUTABLE) + " " + arguments, dir.path());
}

bool contains(const std::string& text, const std::string& fragment) { return text.find(fragment) != std::string::npos; }

class Cli : public ::testing::Test {
 protected:
  test::TempDir dir;
  std::string path(const std::string& name) const { return dir.file(name).string(); }
};

TEST_F(Cli, DemoEditWritesTheMeshAndOneJsonLine) {
  const auto result = run(dir, "edit --shape cactus --steps 4 --out " + path("bent.obj"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto report = nlohmann::json::parse(result.out);
  EXPECT_EQ(report["command"], "edit");
  EXPECT_EQ(report["steps"], 4);
  EXPECT_GT(report["factor_ms"].get<double>(), 0.0);
  EXPECT_GT(report["step_ms"]["median"].get<double>(), 0.0);
  EXPECT_EQ(report["output"], path("bent.obj"));
  const Mesh bent = read_obj(path("bent.obj"));
  EXPECT_EQ(bent.vertex_count(), report["vertices"].get<Eigen::Index>());
  EXPECT_TRUE(contains(result.err, "factoring"));  // progress on stderr
}

TEST_F(Cli, EditFromFilesWithTwoHandlesAndATwist) {
  ASSERT_EQ(run(dir, "edit --shape bar --out " + path("rest.obj") + " --quiet").exit_code, 0);
  const Mesh bar = read_obj(path("rest.obj"));
  std::string fixed, top, middle;
  for (Eigen::Index v = 0; v < bar.vertex_count(); ++v) {
    const double z = bar.positions(v, 2);
    if (z < 0.02) fixed += std::to_string(v) + "\n";
    if (z > 0.98) top += std::to_string(v) + " ";
    if (std::abs(z - 0.5) < 0.01) middle += std::to_string(v) + " ";
  }
  dir.write("fixed.txt", fixed);
  dir.write("top.txt", top);
  dir.write("middle.txt", middle);
  dir.write("twist.txt", "twist 0 0 1  0 0 0  720\n");
  dir.write("move.txt", "1 0 0 0.1\n0 1 0 0\n0 0 1 0\n");
  const auto result = run(dir, "edit --mesh " + path("rest.obj") + " --fixed " + path("fixed.txt") + " --handle " + path("top.txt") +
                                   " --transform " + path("twist.txt") + " --handle " + path("middle.txt") + " --transform " +
                                   path("move.txt") + " --out " + path("out.obj") + " --threads 1");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto report = nlohmann::json::parse(result.out);
  EXPECT_EQ(report["handles"], 2);
  EXPECT_EQ(report["threads"], 1);
  EXPECT_TRUE(contains(result.err, "modulo a full turn"));  // the twist beyond half a turn with two handles
  EXPECT_TRUE(std::filesystem::exists(path("out.obj")));
}

TEST_F(Cli, UsageErrorsExitWithTwo) {
  EXPECT_EQ(run(dir, "").exit_code, 2);
  EXPECT_EQ(run(dir, "edit --shape cactus").exit_code, 2);  // no --out
  EXPECT_EQ(run(dir, "edit --out " + path("x.obj")).exit_code, 2);  // no mesh
  EXPECT_EQ(run(dir, "edit --shape cactus --mesh a.obj --out " + path("x.obj")).exit_code, 2);
  EXPECT_EQ(run(dir, "edit --shape teapot --out " + path("x.obj")).exit_code, 2);
  EXPECT_EQ(run(dir, "edit --shape cactus --backend magic --out " + path("x.obj")).exit_code, 2);
  const auto negative_relief = run(dir, "bench --shape cactus --resolution 12 --relief -0.001 --quiet");
  EXPECT_EQ(negative_relief.exit_code, 2);
  EXPECT_TRUE(contains(negative_relief.err, "--relief must be between 0 and 0.05")) << negative_relief.err;
  dir.write("h.txt", "0\n");
  const auto mismatch = run(dir, "edit --shape cactus --handle " + path("h.txt") + " --out " + path("x.obj"));
  EXPECT_EQ(mismatch.exit_code, 2);
  EXPECT_TRUE(contains(mismatch.err, "one --transform per --handle"));
  EXPECT_FALSE(std::filesystem::exists(path("x.obj")));
  // Vertex lists without the mesh they number: refused, not applied to the built-in cactus.
  // (Checked before any window opens: no display needed.)
  const auto lists_alone = run(dir, "gui --handle " + path("h.txt"));
  EXPECT_EQ(lists_alone.exit_code, 2);
  EXPECT_TRUE(contains(lists_alone.err, "give the mesh too")) << lists_alone.err;
  EXPECT_EQ(run(dir, "gui shape:cactus --up x").exit_code, 2);
  const auto negative_slices = run(dir, "gui shape:cactus --slice-triangles -5");
  EXPECT_EQ(negative_slices.exit_code, 2);
  EXPECT_TRUE(contains(negative_slices.err, "--slice-triangles must be 0")) << negative_slices.err;
  EXPECT_EQ(run(dir, "edit --shape cactus --refine auto --refine-settle 2 --out " + path("x.obj")).exit_code, 2);
}

// The allocator's settings are what editor/main.cpp asks for (a misspelt setting is ignored with
// a warning, and lavapipe's frames of a scan then take four to six times as long), and the user's
// MALLOC_CONF still overrides them. Builds without jemalloc report none.
TEST_F(Cli, BenchReportsTheAllocatorsSettingsAndTheUsersOverrideWins) {
  const auto built = run(dir, "bench --shape cactus --resolution 12 --steps 3 --quiet");
  ASSERT_EQ(built.exit_code, 0) << built.err;
  const auto report = nlohmann::json::parse(built.out);
  const auto& settings = report["allocator_settings"];
  if (report["allocator"] == "glibc") {
    EXPECT_TRUE(settings.empty()) << settings;
    return;
  }
  EXPECT_FALSE(contains(built.err, "<jemalloc>")) << built.err;
  EXPECT_EQ(settings["lg_extent_max_active_fit"], 16) << settings;
  EXPECT_EQ(settings["dirty_decay_ms"], 30000) << settings;
  EXPECT_EQ(settings["muzzy_decay_ms"], -1) << settings;
  EXPECT_EQ(settings["thp"], "default") << settings;
  const auto overridden = test::run_command("MALLOC_CONF=lg_extent_max_active_fit:6,thp:always " + std::string(HDEFORM_EXECUTABLE) +
                                                " bench --shape cactus --resolution 12 --steps 3 --quiet",
                                            dir.path());
  ASSERT_EQ(overridden.exit_code, 0) << overridden.err;
  const auto overridden_settings = nlohmann::json::parse(overridden.out)["allocator_settings"];
  EXPECT_EQ(overridden_settings["lg_extent_max_active_fit"], 6) << overridden_settings;
  EXPECT_EQ(overridden_settings["thp"], "always") << overridden_settings;
  EXPECT_EQ(overridden_settings["muzzy_decay_ms"], -1) << overridden_settings;
}

// Where it solves: said in the report, chosen on the command line or by the session, and the
// session's replay writes what the same options write.
TEST_F(Cli, MultiresolutionOnTheCommandLineAndInASession) {
  const auto multi = run(dir, "edit --shape cactus --multiresolution --base-vertices 600 --refine 3 --out " + path("multi.obj"));
  ASSERT_EQ(multi.exit_code, 0) << multi.err;
  const auto report = nlohmann::json::parse(multi.out);
  EXPECT_EQ(report["resolution"], "multiresolution");
  EXPECT_LE(report["solved_vertices"].get<Eigen::Index>(), 630);
  for (const auto& warning : report["warnings"]) EXPECT_FALSE(contains(warning.get<std::string>(), "asked for")) << warning;
  // A base smaller than the collapses can reach: the report and stderr say what it has instead.
  const auto tiny = run(dir, "edit --shape cactus --multiresolution --base-vertices 4 --out " + path("tiny.obj"));
  ASSERT_EQ(tiny.exit_code, 0) << tiny.err;
  const auto tiny_report = nlohmann::json::parse(tiny.out);
  const auto kept = tiny_report["solved_vertices"].get<Eigen::Index>();
  ASSERT_GT(kept, 4);
  const std::string expected = "the base mesh has " + std::to_string(kept) + " vertices where 4 were asked for";
  ASSERT_EQ(tiny_report["warnings"].size(), 1u) << tiny_report["warnings"];
  EXPECT_TRUE(contains(tiny_report["warnings"][0].get<std::string>(), expected)) << tiny_report["warnings"];
  EXPECT_TRUE(contains(tiny.err, "warning: " + expected)) << tiny.err;
  // bench reports the set-up's warnings too. Its second handle (five vertices) holds no base
  // vertex of its own on a base of 4: it pins a base vertex under it, and the bench solves.
  const auto bench = run(dir, "bench --shape cactus --resolution 12 --steps 3 --quiet --multiresolution --base-vertices 30");
  ASSERT_EQ(bench.exit_code, 0) << bench.err;
  EXPECT_TRUE(nlohmann::json::parse(bench.out)["warnings"].empty());
  const auto tiny_bench = run(dir, "bench --shape cactus --resolution 12 --steps 3 --quiet --multiresolution --base-vertices 4");
  EXPECT_EQ(tiny_bench.exit_code, 0) << tiny_bench.err;
  // A handle of one vertex that is not the base's, everything else fixed: the fixed vertices hold
  // every base vertex already, and the handle is refused by name rather than left empty.
  ASSERT_EQ(run(dir, "edit --shape cactus --resolution 12 --quiet --out " + path("cactus.obj")).exit_code, 0);
  const Mesh small_cactus = read_obj(path("cactus.obj"));
  const auto operators = MeshOperators::of(small_cactus, Resolution::Multiresolution, 4);
  int lone = 0;
  while (operators->multiresolution->encoding.base_vertex(lone) >= 0) ++lone;
  std::string all_but_lone;
  for (int v = 0; v < small_cactus.vertex_count(); ++v) {
    if (v != lone) all_but_lone += std::to_string(v) + "\n";
  }
  dir.write("all-but-one.txt", all_but_lone);
  dir.write("lone.txt", std::to_string(lone) + "\n");
  dir.write("lift.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0.1\n");
  const auto refused = run(dir, "edit --mesh " + path("cactus.obj") + " --fixed " + path("all-but-one.txt") + " --handle " + path("lone.txt") +
                                    " --transform " + path("lift.txt") + " --multiresolution --base-vertices 4 --out " + path("refused.obj"));
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_TRUE(contains(refused.err, "handle 1 (1 vertex) reaches no vertex of the base mesh")) << refused.err;
  EXPECT_FALSE(std::filesystem::exists(path("refused.obj")));
  const auto exact = run(dir, "edit --shape cactus --quiet --out " + path("exact.obj"));
  ASSERT_EQ(exact.exit_code, 0) << exact.err;
  EXPECT_EQ(nlohmann::json::parse(exact.out)["resolution"], "exact");  // a small mesh, by default

  const auto cactus = make_shape(ShapeKind::Cactus, kDefaultShapeResolution);
  nlohmann::json session = {{"format", "hdeform-session"}, {"version", 1}, {"mesh", "shape:cactus"}, {"resolution", "multiresolution"},
                            {"base_vertices", 600}};
  nlohmann::json handle = {{"vertices", cactus.demo_constraints.handles[0]}};
  const auto& t = cactus.demo_transform;
  handle["transform"] = {{"pose", {{"axis", {t.axis.x(), t.axis.y(), t.axis.z()}}, {"pivot", {t.pivot.x(), t.pivot.y(), t.pivot.z()}},
                                   {"angle", t.angle}, {"scale", t.scale}, {"shift", {t.shift.x(), t.shift.y(), t.shift.z()}}}}};
  if (t.kind == HandleTransform::Kind::Affine) {
    std::vector<double> matrix;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) matrix.push_back(t.linear(r, c));
      matrix.push_back(t.translation(r));
    }
    handle["transform"] = {{"matrix", matrix}};
  }
  session["current"] = {{"fixed", cactus.demo_constraints.fixed}, {"handles", nlohmann::json::array({handle})}, {"refine", false}};
  dir.write("multi.json", session.dump(1));
  const auto replay = run(dir, "edit --session " + path("multi.json") + " --quiet --out " + path("replay.obj"));
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  EXPECT_EQ(nlohmann::json::parse(replay.out)["resolution"], "multiresolution");
  const auto plain = run(dir, "edit --shape cactus --multiresolution --base-vertices 600 --quiet --out " + path("plain.obj"));
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(read_obj(path("replay.obj")).positions, read_obj(path("plain.obj")).positions);

  const auto both = run(dir, "edit --shape cactus --exact --multiresolution --out " + path("x.obj"));
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_TRUE(contains(both.err, "contradict")) << both.err;
  const auto overridden = run(dir, "edit --session " + path("multi.json") + " --exact --out " + path("x.obj"));
  EXPECT_EQ(overridden.exit_code, 2);
  EXPECT_TRUE(contains(overridden.err, "says where it solves")) << overridden.err;
  EXPECT_FALSE(std::filesystem::exists(path("x.obj")));
  // The editor alike (before any window opens): its panel changes where a session solves.
  const auto editor = run(dir, "gui --session " + path("multi.json") + " --exact");
  EXPECT_EQ(editor.exit_code, 2);
  EXPECT_TRUE(contains(editor.err, "Solve on")) << editor.err;
}

// --precision single: the report says so and counts the correction steps, the result is the
// double one to 1e-10 of the diagonal, and a session that states its precision refuses another.
TEST_F(Cli, SinglePrecisionFactorsOnTheCommandLineAndInASession) {
  const auto single = run(dir, "edit --shape cactus --precision single --refine 3 --quiet --out " + path("single.obj"));
  ASSERT_EQ(single.exit_code, 0) << single.err;
  const auto report = nlohmann::json::parse(single.out);
  EXPECT_EQ(report["precision"], "single");
  EXPECT_GE(report["correction_steps"].get<int>(), 5);  // the field, the update, three iterations
  const auto in_double = run(dir, "edit --shape cactus --refine 3 --quiet --out " + path("double.obj"));
  ASSERT_EQ(in_double.exit_code, 0) << in_double.err;
  EXPECT_EQ(nlohmann::json::parse(in_double.out)["precision"], "double");
  EXPECT_EQ(nlohmann::json::parse(in_double.out)["correction_steps"], 0);
  const Eigen::MatrixXd a = read_obj(path("single.obj")).positions, b = read_obj(path("double.obj")).positions;
  EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-10 * bounding_box_diagonal(b));

  const auto field = run(dir, "field --shape cactus --precision single --out " + path("field.txt"));
  ASSERT_EQ(field.exit_code, 0) << field.err;
  EXPECT_EQ(nlohmann::json::parse(field.out)["precision"], "single");
  const auto unknown = run(dir, "edit --shape cactus --precision half --out " + path("x.obj"));
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_TRUE(contains(unknown.err, "--precision")) << unknown.err;

  dir.write("single.json", R"({"format": "hdeform-session", "version": 1, "mesh": "shape:cactus", "precision": "single", "current": {}})");
  const auto overridden = run(dir, "edit --session " + path("single.json") + " --precision double --out " + path("x.obj"));
  EXPECT_EQ(overridden.exit_code, 2);
  EXPECT_TRUE(contains(overridden.err, "says how its factors are stored")) << overridden.err;
  EXPECT_FALSE(std::filesystem::exists(path("x.obj")));
}

TEST_F(Cli, BadDataExitsWithOneNamesTheFileAndWritesNothing) {
  dir.write("h.txt", "0 1 2\n");
  dir.write("f.txt", "100 101\n");
  dir.write("singular.txt", "1 0 0 0\n0 1 0 0\n0 0 0 0\n");
  dir.write("short.txt", "1 0 0 0\n0 1 0 0\n");
  dir.write("range.txt", "0 1\n99999999\n");
  dir.write("both.txt", "5 0\n");
  dir.write("id.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  const std::string out = " --out " + path("x.obj");
  struct Case {
    std::string arguments;
    std::string fragment;
  };
  const std::vector<Case> cases{
      {"edit --mesh " + path("missing.obj") + " --handle " + path("h.txt") + " --transform " + path("id.txt"), "missing.obj"},
      {"edit --shape cactus --handle " + path("h.txt") + " --transform " + path("singular.txt"), "singular"},
      {"edit --shape cactus --handle " + path("h.txt") + " --transform " + path("short.txt"), "short.txt:2: the numbers end after 8; expected 12"},
      {"edit --shape cactus --handle " + path("range.txt") + " --transform " + path("id.txt"), "range.txt:2: vertex 99999999 out of range"},
      {"edit --shape cactus --fixed " + path("both.txt") + " --handle " + path("h.txt") + " --transform " + path("id.txt"),
       "h.txt: vertex 0 is also listed in"},
      {"edit --shape cactus --handle " + path("missing-h.txt") + " --transform " + path("id.txt"), "missing-h.txt"},
  };
  for (const auto& c : cases) {
    const auto result = run(dir, c.arguments + out);
    EXPECT_EQ(result.exit_code, 1) << c.arguments;
    EXPECT_TRUE(contains(result.err, c.fragment)) << "'" << c.fragment << "' not in: " << result.err;
    EXPECT_FALSE(std::filesystem::exists(path("x.obj"))) << c.arguments;
  }
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) files += entry.path().filename().string().starts_with(".") ? 1000 : 1;
  EXPECT_LT(files, 1000) << "a temporary file was left behind";
}

TEST_F(Cli, NeverOverwritesItsInput) {
  ASSERT_EQ(run(dir, "edit --shape sphere --out " + path("in.obj") + " --quiet").exit_code, 0);
  const auto before = std::filesystem::last_write_time(path("in.obj"));
  dir.write("h.txt", "0\n");
  dir.write("id.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  const auto result = run(dir, "edit --mesh " + path("in.obj") + " --handle " + path("h.txt") + " --transform " + path("id.txt") +
                                   " --out " + path("in.obj"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_TRUE(contains(result.err, "refusing to overwrite"));
  EXPECT_EQ(std::filesystem::last_write_time(path("in.obj")), before);
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The benchmark as published (labels and a 4×4 matrix, as CGAL's demo reads them) gives exactly
// the result of the converted index files.
TEST_F(Cli, SelAndDefFilesGiveTheIndexFilesResult) {
  HDEFORM_REQUIRE_SHARED_MESHES();
  const auto folder = test::shared_meshes() / "deformation-benchmark";
  for (const std::string name : {"bar", "cactus", "cylinder", "plane"}) {
    SCOPED_TRACE(name);
    const std::string base = (folder / name).string();
    const auto labels = run(dir, "edit --mesh " + base + ".obj --sel " + base + ".sel --def " + base + ".def --out " + path(name + "-sel.obj") + " --quiet");
    ASSERT_EQ(labels.exit_code, 0) << labels.err;
    const auto indices = run(dir, "edit --mesh " + base + ".obj --fixed " + base + "-fixed.txt --handle " + base + "-handle.txt --transform " + base +
                                      "-transform.txt --out " + path(name + "-indices.obj") + " --quiet");
    ASSERT_EQ(indices.exit_code, 0) << indices.err;
    EXPECT_EQ(file_bytes(path(name + "-sel.obj")), file_bytes(path(name + "-indices.obj")));
    const auto report = nlohmann::json::parse(labels.out);
    EXPECT_GT(report["free"].get<int>(), 0);
  }
}

TEST_F(Cli, SelAndDefAreRefusedWithTheOtherConstraintOptions) {
  dir.write("labels.sel", "2\n");
  dir.write("move.def", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  for (const std::string& extra : {"--def " + path("move.def") + " --fixed " + path("labels.sel"), std::string()}) {
    const auto result = run(dir, "edit --shape cactus --sel " + path("labels.sel") + " " + extra + " --out " + path("out.obj"));
    EXPECT_EQ(result.exit_code, 2) << result.err;
    EXPECT_TRUE(contains(result.err, "--sel")) << result.err;
  }
  EXPECT_FALSE(std::filesystem::exists(path("out.obj")));
}

TEST_F(Cli, FieldWritesOneValuePerVertex) {
  ASSERT_EQ(run(dir, "edit --shape cylinder --out " + path("c.obj") + " --quiet").exit_code, 0);
  const Mesh mesh = read_obj(path("c.obj"));
  dir.write("sources.txt", "0\n");
  dir.write("sinks.txt", std::to_string(mesh.vertex_count() - 1) + "\n");
  const auto result = run(dir, "field --mesh " + path("c.obj") + " --sources " + path("sources.txt") + " --sinks " +
                                   path("sinks.txt") + " --out " + path("h.txt"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  std::ifstream in(path("h.txt"));
  std::vector<double> values;
  for (double value; in >> value;) values.push_back(value);
  ASSERT_EQ(values.size(), static_cast<std::size_t>(mesh.vertex_count()));
  EXPECT_EQ(values.front(), 1.0);
  EXPECT_EQ(values.back(), 0.0);
  EXPECT_GE(*std::min_element(values.begin(), values.end()), 0.0);
  EXPECT_LE(*std::max_element(values.begin(), values.end()), 1.0);
}

class TransferCli : public Cli {
 protected:
  void SetUp() override {
    const auto shape = make_shape(ShapeKind::Cactus, 16);
    write_obj(path("rest.obj"), shape.mesh);
    rest = read_obj(path("rest.obj"));
    Deformer deformer(rest, shape.demo_constraints);
    Eigen::MatrixXd bent;
    deformer.deform(std::span(&shape.demo_transform, 1), bent);
    write_obj(path("bent.obj"), Mesh{bent, rest.triangles});
    write_obj(path("moved.obj"), Mesh{rest.positions.rowwise() + Eigen::RowVector3d(0.5, 0.0, 0.25), rest.triangles});
    std::string pairs = "# the same vertices on both sides\n";
    for (Eigen::Index v = 0; v < rest.vertex_count(); v += rest.vertex_count() / 16) pairs += std::to_string(v) + " " + std::to_string(v) + "\n";
    dir.write("markers.txt", pairs);
  }
  std::string transfer(const std::string& extra) const {
    return "transfer --source-rest " + path("rest.obj") + " --target " + path("rest.obj") + " --markers " + path("markers.txt") + " " + extra;
  }
  Mesh rest;
};

TEST_F(TransferCli, WritesEveryPoseAndReportsCountsTimingsAndErrors) {
  const auto result = run(dir, transfer("--source-pose " + path("bent.obj") + " " + path("moved.obj") + " --out-dir " + path("out") +
                                        " --expected " + path("bent.obj") + " " + path("moved.obj")));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto report = nlohmann::json::parse(result.out);
  EXPECT_EQ(report["command"], "transfer");
  EXPECT_EQ(report["method"], "correspondence");
  EXPECT_EQ(report["poses"], 2);
  EXPECT_EQ(report["markers"], 17);
  EXPECT_EQ(report["factorizations"], 3);
  EXPECT_EQ(report["mismatched_triangles"], 0);
  EXPECT_GT(report["setup_ms"]["correspondence"].get<double>(), 0.0);
  EXPECT_GT(report["pose_ms"]["median"].get<double>(), 0.0);
  EXPECT_LT(report["mean_error"].get<double>(), 1e-9);
  // Source and target are one mesh with markers on the same vertices: the poses come back.
  const double diagonal = (rest.positions.colwise().maxCoeff() - rest.positions.colwise().minCoeff()).norm();
  EXPECT_LE((read_obj(path("out/bent.obj")).positions - read_obj(path("bent.obj")).positions).cwiseAbs().maxCoeff(), 1e-9 * diagonal);
  EXPECT_LE((read_obj(path("out/moved.obj")).positions - read_obj(path("moved.obj")).positions).cwiseAbs().maxCoeff(), 1e-9 * diagonal);
  EXPECT_TRUE(contains(result.err, "pose 2/2"));  // progress through the sequence

  const auto interpolated = run(dir, transfer("--method interpolation --source-pose " + path("bent.obj") + " --out-dir " + path("interp")));
  ASSERT_EQ(interpolated.exit_code, 0) << interpolated.err;
  EXPECT_EQ(nlohmann::json::parse(interpolated.out)["factorizations"], 2);
  EXPECT_TRUE(std::filesystem::exists(path("interp/bent.obj")));
}

// Every factor of a transfer (coordinates, mismatch fill, reconstruction) in single precision:
// the same poses to 1e-10 of the diagonal.
TEST_F(TransferCli, SinglePrecisionFactorsGiveTheSamePoses) {
  for (const std::string precision : {"double", "single"}) {
    const auto result = run(dir, transfer("--source-pose " + path("bent.obj") + " --out-dir " + path(precision) + " --precision " + precision));
    ASSERT_EQ(result.exit_code, 0) << result.err;
    const auto report = nlohmann::json::parse(result.out);
    EXPECT_EQ(report["precision"], precision);
    EXPECT_EQ(report["single_precision_factorizations"], precision == "single" ? report["factorizations"].get<int>() : 0);
  }
  const double diagonal = (rest.positions.colwise().maxCoeff() - rest.positions.colwise().minCoeff()).norm();
  EXPECT_LE((read_obj(path("single/bent.obj")).positions - read_obj(path("double/bent.obj")).positions).cwiseAbs().maxCoeff(), 1e-10 * diagonal);
}

TEST_F(TransferCli, BadInputExitsWithOneAndWritesNothing) {
  dir.write("bad-markers.txt", "0 0\n1 999999\n2 2\n");
  auto result = run(dir, "transfer --source-rest " + path("rest.obj") + " --target " + path("rest.obj") + " --markers " + path("bad-markers.txt") +
                             " --source-pose " + path("bent.obj") + " --out-dir " + path("out"));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_TRUE(contains(result.err, "bad-markers.txt:2: target vertex 999999 out of range")) << result.err;
  EXPECT_FALSE(std::filesystem::exists(path("out")));

  const auto sphere = make_shape(ShapeKind::Sphere, 12);
  write_obj(path("sphere.obj"), sphere.mesh);
  result = run(dir, transfer("--source-pose " + path("bent.obj") + " " + path("sphere.obj") + " --out-dir " + path("out")));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_TRUE(contains(result.err, "sphere.obj: a pose must have the source rest mesh's vertices and triangles")) << result.err;
  EXPECT_FALSE(std::filesystem::exists(path("out/bent.obj")));

  EXPECT_EQ(run(dir, transfer("--source-column 3 --source-pose " + path("bent.obj") + " --out-dir " + path("out"))).exit_code, 2);
  EXPECT_EQ(run(dir, transfer("--method nearest --source-pose " + path("bent.obj") + " --out-dir " + path("out"))).exit_code, 2);
  // Two poses named alike would overwrite each other; a pose's own folder would be overwritten.
  std::filesystem::create_directories(path("other"));
  std::filesystem::copy_file(path("bent.obj"), path("other/bent.obj"));
  EXPECT_EQ(run(dir, transfer("--source-pose " + path("bent.obj") + " " + path("other/bent.obj") + " --out-dir " + path("out"))).exit_code, 2);
  result = run(dir, transfer("--source-pose " + path("bent.obj") + " --out-dir " + dir.path().string()));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_TRUE(contains(result.err, "refusing to overwrite"));
}

TEST_F(TransferCli, CorrespondenceWritesTheMap) {
  const auto result = run(dir, "correspondence --source-rest " + path("rest.obj") + " --target " + path("rest.obj") + " --markers " +
                                   path("markers.txt") + " --source-column 2 --out " + path("map.txt"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(nlohmann::json::parse(result.out)["source_triangles_matched"], rest.triangle_count());
  std::ifstream in(path("map.txt"));
  std::string line;
  std::getline(in, line);  // the header comment
  Eigen::Index count = 0;
  for (long target = 0, source = 0; in >> target >> source && std::getline(in, line); ++count) EXPECT_EQ(target, source);
  EXPECT_EQ(count, rest.triangle_count());
}

}  // namespace
}  // namespace hdeform

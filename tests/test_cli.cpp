// The hdeform executable as a user meets it: exit codes, messages, outputs.
#include <nlohmann/json.hpp>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "hdeform/mesh_io.h"
#include "test_support.h"

namespace hdeform {
namespace {

struct Run {
  int exit_code;
  std::string out;
  std::string err;
};

Run run(const test::TempDir& dir, const std::string& arguments) {
  const auto err_file = dir.file("stderr.txt");
  const std::string command = std::string(HDEFORM_EXECUTABLE) + " " + arguments + " 2>" + err_file.string();
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  std::array<char, 4096> buffer;
  while (const auto n = std::fread(buffer.data(), 1, buffer.size(), pipe)) out.append(buffer.data(), n);
  const int status = pclose(pipe);
  std::ifstream err_stream(err_file);
  std::stringstream err;
  err << err_stream.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out, err.str()};
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
  dir.write("h.txt", "0\n");
  const auto mismatch = run(dir, "edit --shape cactus --handle " + path("h.txt") + " --out " + path("x.obj"));
  EXPECT_EQ(mismatch.exit_code, 2);
  EXPECT_TRUE(contains(mismatch.err, "one --transform per --handle"));
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
      {"edit --shape cactus --handle " + path("h.txt") + " --transform " + path("short.txt"), "expected 12 numbers"},
      {"edit --shape cactus --handle " + path("range.txt") + " --transform " + path("id.txt"), "range.txt:2: vertex 99999999 out of range"},
      {"edit --shape cactus --fixed " + path("both.txt") + " --handle " + path("h.txt") + " --transform " + path("id.txt"),
       "both fixed and in handle 1"},
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

}  // namespace
}  // namespace hdeform

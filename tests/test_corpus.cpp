// Hostile input: every file in tests/corpus/bad through every command that reads that kind of
// file, in every place it goes. Each run must exit with 1, print the file, the line and the
// problem as tests/corpus/bad/EXPECTED says, and leave nothing behind: no output, no temporary
// file. The legal-but-hard meshes of tests/corpus/hard must deform, with a warning where the user
// should know.
#include <nlohmann/json.hpp>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <future>
#include <map>
#include <set>
#include <sstream>

#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

const std::filesystem::path kCorpus = std::filesystem::path(HDEFORM_SOURCE_DIR) / "tests" / "corpus";

using Outcome = test::CommandOutcome;

// Runs hdeform with `arguments` in `folder` (its working directory). A command that draws gets
// back the Vulkan driver that sanitizer runs preload (tests/CMakeLists.txt says why the others
// start without it).
Outcome run_in(const std::filesystem::path& folder, const std::string& arguments) {
  std::string preload;
  if (arguments.starts_with("render ")) {
    if (const char* driver = std::getenv("HDEFORM_VULKAN_PRELOAD"); driver != nullptr && *driver != '\0') {
      preload = "LD_PRELOAD='" + std::string(driver) + "' ";
    }
  }
  return test::run_command("cd '" + folder.string() + "' && " + preload + HDEFORM_EXECUTABLE + " " + arguments, folder);
}

std::set<std::string> listing(const std::filesystem::path& folder) {
  std::set<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) names.insert(entry.path().filename().string());
  return names;
}

// Where each kind of file goes: a command line with BAD in the place under test and good files
// everywhere else, and the good file that normally stands in that place.
struct Place {
  const char* command;
  const char* good;
};
const std::map<std::string, std::vector<Place>>& places() {
  static const std::map<std::string, std::vector<Place>> table = {
      {"mesh",
       {{"edit --mesh BAD --fixed fixed.txt --handle handle.txt --transform move.txt --out out.obj", "good.obj"},
        {"field --mesh BAD --sources handle.txt --sinks fixed.txt --out out.txt", "good.obj"},
        {"bench --mesh BAD --fixed fixed.txt --handle handle.txt --transform move.txt --steps 3 --out out.json --quiet", "good.obj"},
        {"transfer --source-rest BAD --target good.obj --markers markers.txt --source-pose good.obj --out-dir out", "good.obj"},
        {"transfer --source-rest good.obj --target BAD --markers markers.txt --source-pose good.obj --out-dir out", "good.obj"},
        {"transfer --source-rest good.obj --target good.obj --markers markers.txt --source-pose BAD --out-dir out", "good.obj"},
        {"correspondence --source-rest BAD --target good.obj --markers markers.txt --out out.txt", "good.obj"},
        {"correspondence --source-rest good.obj --target BAD --markers markers.txt --out out.txt", "good.obj"},
#if HDEFORM_HAS_RENDER
        {"render --mesh BAD --out out.png", "good.obj"},
#endif
       }},
      {"indices",
       {{"edit --mesh good.obj --fixed BAD --handle handle.txt --transform move.txt --out out.obj", "fixed.txt"},
        {"edit --mesh good.obj --fixed fixed.txt --handle BAD --transform move.txt --out out.obj", "handle.txt"},
        {"edit --mesh good.obj --fixed fixed.txt --handle handle.txt --transform move.txt --roi BAD --out out.obj", "roi.txt"},
        {"field --mesh good.obj --sources BAD --sinks fixed.txt --out out.txt", "handle.txt"},
        {"field --mesh good.obj --sources handle.txt --sinks BAD --out out.txt", "fixed.txt"},
        {"bench --mesh good.obj --fixed BAD --handle handle.txt --transform move.txt --steps 3 --out out.json --quiet", "fixed.txt"},
        {"bench --mesh good.obj --fixed fixed.txt --handle BAD --transform move.txt --steps 3 --out out.json --quiet", "handle.txt"},
#if HDEFORM_HAS_RENDER
        {"render --mesh good.obj --fixed BAD --handle handle.txt --out out.png", "fixed.txt"},
        {"render --mesh good.obj --fixed fixed.txt --handle BAD --out out.png", "handle.txt"},
#endif
       }},
      {"transform",
       {{"edit --mesh good.obj --fixed fixed.txt --handle handle.txt --transform BAD --out out.obj", "move.txt"},
        {"bench --mesh good.obj --fixed fixed.txt --handle handle.txt --transform BAD --steps 3 --out out.json --quiet", "move.txt"}}},
      {"markers",
       {{"transfer --source-rest good.obj --target good.obj --markers BAD --source-pose good.obj --out-dir out", "markers.txt"},
        {"correspondence --source-rest good.obj --target good.obj --markers BAD --out out.txt", "markers.txt"}}},
      {"session", {{"edit --session BAD --out out.obj", "session.json"}}},
      {"sel", {{"edit --mesh good.obj --sel BAD --def move.txt --out out.obj", "labels.sel"}}},
#if HDEFORM_HAS_RENDER
      {"values", {{"render --mesh good.obj --field BAD --out out.png", "values.txt"}}},
#else
      {"values", {}},
#endif
  };
  return table;
}

std::string kind_of(const std::string& name) {
  if (mesh_format_of(name)) return "mesh";
  return name.substr(0, name.find('-'));
}

std::string comma_list(const std::vector<int>& values) {
  std::string text;
  for (const int v : values) text += (text.empty() ? "" : ", ") + std::to_string(v);
  return text;
}

class Corpus : public ::testing::Test {
 protected:
  // A folder of good files, the same for every run: a small cactus, its constraints, markers
  // and values.
  static std::filesystem::path make_good_files(const test::TempDir& dir) {
    const auto shape = make_shape(ShapeKind::Cactus, 8);
    write_obj(dir.file("good.obj"), shape.mesh);
    std::string fixed, handle;
    for (const int v : shape.demo_constraints.fixed) fixed += std::to_string(v) + "\n";
    for (const int v : shape.demo_constraints.handles[0]) handle += std::to_string(v) + "\n";
    dir.write("fixed.txt", fixed);
    dir.write("handle.txt", handle);
    dir.write("move.txt", "1 0 0 0.05\n0 1 0 0\n0 0 1 0.02\n");
    std::vector<char> labels(static_cast<std::size_t>(shape.mesh.vertex_count()), '1');
    for (const int v : shape.demo_constraints.fixed) labels[static_cast<std::size_t>(v)] = '0';
    for (const int v : shape.demo_constraints.handles[0]) labels[static_cast<std::size_t>(v)] = '2';
    std::string label_lines;
    for (const char label : labels) label_lines += std::string(1, label) + "\n";
    dir.write("labels.sel", label_lines);
    dir.write("markers.txt", "0 0\n40 40\n120 120\n200 200\n300 300\n");
    std::string roi;
    for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) roi += std::to_string(v) + "\n";
    dir.write("roi.txt", roi);
    dir.write("session.json", "{\"format\": \"hdeform-session\", \"version\": 1, \"mesh\": \"good.obj\", \"current\": {\"fixed\": [" + comma_list(shape.demo_constraints.fixed) +
                                  "], \"handles\": [{\"vertices\": [" + comma_list(shape.demo_constraints.handles[0]) +
                                  "], \"transform\": {\"matrix\": [1, 0, 0, 0.05, 0, 1, 0, 0, 0, 0, 1, 0]}}]}}\n");
    std::string values;
    for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) values += std::to_string(static_cast<double>(v) / static_cast<double>(shape.mesh.vertex_count())) + "\n";
    dir.write("values.txt", values);
    return dir.path();
  }
};

TEST_F(Corpus, EveryCommandRefusesEveryBadFileNamingTheLineAndWritesNothing) {
  std::vector<std::pair<std::string, std::string>> expected;  // file, message after its path
  std::ifstream manifest(kCorpus / "bad" / "EXPECTED");
  ASSERT_TRUE(manifest) << "tests/corpus/bad/EXPECTED is missing";
  for (std::string line; std::getline(manifest, line);) {
    if (line.empty() || line[0] == '#') continue;
    const auto space = line.find(' ');
    const auto message = line.find_first_not_of(' ', space);
    expected.emplace_back(line.substr(0, space), line.substr(message));
  }
  // Every corpus file is listed, and every listed file exists.
  std::set<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(kCorpus / "bad")) {
    if (entry.path().filename() != "EXPECTED") files.insert(entry.path().filename().string());
  }
  std::set<std::string> listed;
  for (const auto& [file, message] : expected) listed.insert(file);
  EXPECT_EQ(files, listed) << "tests/corpus/bad and its EXPECTED disagree";

  // Two workers, each with its own folder of good files.
  const test::TempDir dirs[2];
  for (const auto& dir : dirs) make_good_files(dir);
  // The good files pass every command line (so that a refusal below is the bad file's doing).
  for (const auto& [kind, kind_places] : places()) {
    for (const auto& place : kind_places) {
      std::string line = place.command;
      line.replace(line.find("BAD"), 3, place.good);
      const Outcome run = run_in(dirs[0].path(), line + " --quiet");
      EXPECT_EQ(run.exit_code, 0) << line << "\n" << run.err;
      std::filesystem::remove_all(dirs[0].file("out"));
      for (const char* output : {"out.obj", "out.txt", "out.json", "out.png"}) std::filesystem::remove(dirs[0].file(output));
    }
  }
  const auto good_listing = listing(dirs[0].path());

  std::vector<std::tuple<std::string, std::string, std::string>> runs;  // file, message, command line
  for (const auto& [file, message] : expected) {
    const auto kind = kind_of(file);
    ASSERT_TRUE(places().count(kind)) << file << ": no place for this kind of file";
    for (const auto& place : places().at(kind)) runs.emplace_back(file, message, place.command);
  }
  auto worker = [&](std::size_t first, const test::TempDir& dir) {
    std::vector<std::string> failures;
    for (std::size_t k = first; k < runs.size(); k += 2) {
      const auto& [file, message, command] = runs[k];
      const std::string bad = (kCorpus / "bad" / file).string();
      std::string line = command;
      line.replace(line.find("BAD"), 3, "'" + bad + "'");
      const Outcome run = run_in(dir.path(), line);
      std::ostringstream why;
      if (run.exit_code != 1) why << "exit code " << run.exit_code << " (expected 1); ";
      if (run.err.find(bad + message) == std::string::npos) why << "message lacks '" << bad + message << "'; ";
      const auto after = listing(dir.path());
      if (after != good_listing) why << "left files behind; ";
      if (!why.str().empty()) failures.push_back(line + "\n    " + why.str() + "\n    stderr: " + run.err);
      for (const auto& name : after) {
        if (!good_listing.count(name)) std::filesystem::remove_all(dir.file(name));
      }
    }
    return failures;
  };
  auto second = std::async(std::launch::async, worker, 1, std::cref(dirs[1]));
  auto failures = worker(0, dirs[0]);
  const auto more = second.get();
  failures.insert(failures.end(), more.begin(), more.end());
  for (const auto& failure : failures) ADD_FAILURE() << failure;
  EXPECT_GT(runs.size(), 150u);
}

// The OBJ inputs the fuzzer keeps (its seeds and every input that once crashed a reader) through
// every command that reads a mesh, once with the good files beside it and once with constraints
// and markers that fit a mesh of 4 or 5 vertices: each run ends cleanly, with success or exit 1
// naming a file, never a crash (under ASan+UBSan, never a report), and a refusal writes nothing.
TEST_F(Corpus, FuzzFoundMeshesGetACleanOutcomeFromEveryCommand) {
  const test::TempDir dir;
  make_good_files(dir);
  dir.write("tiny-fixed.txt", "1\n");
  dir.write("tiny-handle.txt", "3\n");
  dir.write("tiny-markers.txt", "1 1\n2 2\n3 3\n");
  std::vector<std::string> lines;
  for (const auto& place : places().at("mesh")) lines.emplace_back(place.command);
  for (const std::string tiny : {"edit --mesh BAD --fixed tiny-fixed.txt --handle tiny-handle.txt --transform move.txt --out out.obj",
                                 "field --mesh BAD --sources tiny-handle.txt --sinks tiny-fixed.txt --out out.txt",
                                 "transfer --source-rest BAD --target BAD --markers tiny-markers.txt --source-pose BAD --out-dir out",
                                 "correspondence --source-rest BAD --target BAD --markers tiny-markers.txt --out out.txt"}) {
    lines.push_back(tiny);
  }
  const auto before = listing(dir.path());
  std::size_t runs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kCorpus.parent_path() / "fuzz" / "corpus" / "obj")) {
    const std::string mesh = entry.path().string();
    for (std::string line : lines) {
      for (std::size_t at; (at = line.find("BAD")) != std::string::npos;) line.replace(at, 3, "'" + mesh + "'");
      const Outcome run = run_in(dir.path(), line + " --quiet");
      ++runs;
      EXPECT_TRUE(run.exit_code == 0 || run.exit_code == 1) << line << "\nexit code " << run.exit_code << "\n" << run.err;
      if (run.exit_code == 1) {
        EXPECT_TRUE(run.err.starts_with("hdeform: ") && run.err.find(": ", 9) != std::string::npos) << line << "\n" << run.err;
        EXPECT_EQ(listing(dir.path()), before) << line << ": a refusal left files behind";
      }
      for (const auto& name : listing(dir.path())) {
        if (!before.count(name)) std::filesystem::remove_all(dir.file(name));
      }
    }
  }
  EXPECT_GE(runs, 4 * lines.size());
}

TEST_F(Corpus, ContradictoryConstraintsNameBothFiles) {
  const test::TempDir dir;
  make_good_files(dir);
  dir.write("also-fixed.txt", "40\n" + std::to_string(make_shape(ShapeKind::Cactus, 8).demo_constraints.fixed[0]) + "\n");
  for (const std::string command : {"edit --mesh good.obj --fixed fixed.txt --handle also-fixed.txt --transform move.txt --out out.obj",
                                    "field --mesh good.obj --sources also-fixed.txt --sinks fixed.txt --out out.txt"}) {
    const Outcome run = run_in(dir.path(), command);
    EXPECT_EQ(run.exit_code, 1) << command;
    EXPECT_NE(run.err.find("also-fixed.txt: vertex"), std::string::npos) << run.err;
    EXPECT_NE(run.err.find("is also listed in fixed.txt"), std::string::npos) << run.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("out.obj")) || std::filesystem::exists(dir.file("out.txt")));
  }
}

// Legal but hard: each mesh in tests/corpus/hard deforms with its own fixed and handle files,
// gives finite positions, keeps fixed vertices in place, and warns as HARD says.
TEST_F(Corpus, HardButLegalMeshesDeformWithTheirWarnings) {
  std::ifstream manifest(kCorpus / "hard" / "HARD");
  ASSERT_TRUE(manifest) << "tests/corpus/hard/HARD is missing";
  const test::TempDir dir;
  std::size_t cases = 0;
  for (std::string line; std::getline(manifest, line);) {
    if (line.empty() || line[0] == '#') continue;
    const auto space = line.find(' ');
    const std::string name = line.substr(0, space);
    const std::string warning = space == std::string::npos ? "" : line.substr(line.find_first_not_of(' ', space));
    const auto base = (kCorpus / "hard" / name).string();
    const std::string out = dir.file(name + "-out.obj").string();
    const auto transform = std::filesystem::exists(base + "-transform.txt") ? base + "-transform.txt" : (kCorpus / "hard" / "move.txt").string();
    const Outcome run = run_in(dir.path(), "edit --mesh " + base + ".obj --fixed " + base + "-fixed.txt --handle " + base + "-handle.txt --transform " +
                                           transform + " --out " + out);
    ++cases;
    ASSERT_EQ(run.exit_code, 0) << name << "\n" << run.err;
    if (warning != "-") {
      bool warned = false;
      std::istringstream lines(run.err);
      for (std::string said; std::getline(lines, said);) warned |= said.starts_with("hdeform: warning: ") && said.find(warning) != std::string::npos;
      EXPECT_TRUE(warned) << name << ": no warning with '" << warning << "'\n" << run.err;
    }
    const Mesh input = read_obj(base + ".obj");
    const Mesh result = read_obj(out);
    ASSERT_EQ(result.vertex_count(), input.vertex_count());
    EXPECT_TRUE(result.positions.allFinite()) << name;
    std::ifstream fixed(base + "-fixed.txt");
    for (int v = 0; fixed >> v;) EXPECT_EQ(result.positions.row(v), input.positions.row(v)) << name << ", fixed vertex " << v;
    std::ifstream handle(base + "-handle.txt");
    double moved = 0.0;
    for (int v = 0; handle >> v;) moved = std::max(moved, (result.positions.row(v) - input.positions.row(v)).norm());
    EXPECT_GT(moved, 0.0) << name << ": the handle did not move";
  }
  EXPECT_GE(cases, 11u);
}

}  // namespace
}  // namespace hdeform

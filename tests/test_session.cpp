#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/shapes.h"
#include "commands/cli_support.h"
#include "model/session.h"
#include "test_support.h"

namespace hdeform {
namespace {

using cli::Session;

Session demo_session(int resolution = 24) {
  const auto shape = make_shape(ShapeKind::Cactus, resolution);
  Session session;
  session.mesh = "shape:cactus:" + std::to_string(resolution);
  session.current.fixed = shape.demo_constraints.fixed;
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
  for (const int v : shape.demo_constraints.handles[0]) pivot += shape.mesh.positions.row(v).transpose();
  pivot /= static_cast<double>(shape.demo_constraints.handles[0].size());
  session.current.handles.push_back(
      {shape.demo_constraints.handles[0], HandleTransform::about_pivot(Eigen::Vector3d(1, 0.2, 0), pivot, 1.3, 1.1, Eigen::Vector3d(0.0, -0.05, 0.02))});
  return session;
}

// The one reading of a mesh name ("shape:NAME[:RESOLUTION]" or a path) and of WIDTHxHEIGHT.
TEST(Session, MeshNamesAndSizesAreReadOneWayEverywhere) {
  const auto bar = cli::MeshSource::from_name("shape:bar:24");
  EXPECT_EQ(bar.shape_name, "bar");
  EXPECT_EQ(bar.resolution, 24);
  EXPECT_EQ(bar.describe(), "shape:bar:24");
  EXPECT_EQ(cli::MeshSource::from_name("shape:cactus").resolution, 0);
  EXPECT_EQ(cli::MeshSource::from_name("/meshes/shape.obj").mesh_path, "/meshes/shape.obj");
  EXPECT_FALSE(cli::MeshSource::from_name("/meshes/shape.obj").is_shape());
  for (const char* bad : {"shape:nope", "shape:bar:", "shape:bar:x", "shape:bar:12x", "shape:bar:0", "shape:bar:-4"}) {
    EXPECT_THROW(cli::MeshSource::from_name(bad), InputError) << bad;
  }
  cli::Session session;
  session.mesh = "shape:bar:12x";
  try {
    cli::load_session_mesh(session);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& error) {
    EXPECT_EQ(std::string(error.what()), "session mesh 'shape:bar:12x': the resolution '12x' is not a positive number");
  }
  EXPECT_EQ(cli::parse_size("1280x800", "--size", 320, 240, 8192), std::pair(1280u, 800u));
  for (const char* bad : {"1280x800x", "1280", "x800", "100x800", "1280 800", "9000x800", "1280x800 "}) {
    EXPECT_THROW(cli::parse_size(bad, "--size", 320, 240, 8192), cli::UsageError) << bad;
  }
}

// The current stage's result by hand: a fresh Deformer, the paper's update, refined from it until
// `refinement` says stop; also its status.
std::pair<Eigen::MatrixXd, RefinementStatus> refined_by_hand(const Mesh& base, const Session& session, const RefinementOptions& refinement) {
  DeformerOptions options;
  options.prepare_refinement = true;
  options.refinement = refinement;
  Deformer deformer(base, session.current.constraints(), options);
  Eigen::MatrixXd positions;
  deformer.deform(session.current.transforms(), positions);
  deformer.refine(positions, refinement.max_iterations);
  return {positions, deformer.refinement_status()};
}

TEST(Session, RoundTripsExactly) {
  const test::TempDir dir;
  Session session = demo_session();
  Eigen::Matrix<double, 3, 4> affine;
  affine << Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()).toRotationMatrix() * 1.2, Eigen::Vector3d(0.1, 0.2, 0.3);
  session.current.handles.push_back({{1, 2, 3}, HandleTransform::from_affine(affine)});
  session.current.region_of_interest = {0, 1, 2, 3, 4, 5};
  session.applied.push_back(session.current);
  session.applied.back().refine = true;
  session.active_handle = 1;
  cli::write_session(dir.file("s.json"), session);
  Session back = cli::read_session(dir.file("s.json"));
  EXPECT_EQ(back, session);
  back.current.handles[0].transform.angle += 1e-15;
  back.current.handles[0].transform = HandleTransform::about_pivot(back.current.handles[0].transform.axis, back.current.handles[0].transform.pivot,
                                                                  back.current.handles[0].transform.angle, 1.1, back.current.handles[0].transform.shift);
  EXPECT_FALSE(back == session);  // the comparison can tell
  back = cli::read_session(dir.file("s.json"));
  back.applied[0].refine = false;
  EXPECT_FALSE(back == session);  // ... also the refinement setting
  session.current.refine = true;
  session.current.refine_settle = kEditorSettle;
  cli::write_session(dir.file("settled.json"), session);
  back = cli::read_session(dir.file("settled.json"));
  EXPECT_EQ(back, session);
  back.current.refine_settle = 0.0;
  EXPECT_FALSE(back == session);  // ... and where it stops
}

// The editor's sessions carry its settle test: the replay stops where the editor stopped, at the
// first iteration the settle test accepts, which is earlier than the energy test alone.
TEST(Session, ARefinedStageStopsWhereItsSettleTestSays) {
  Session session = demo_session();
  session.current.refine = true;
  const Mesh base = cli::load_session_mesh(session);
  const Eigen::MatrixXd converged = cli::replay_session(session, base, {});
  session.current.refine_settle = 1e-3;
  const Eigen::MatrixXd settled = cli::replay_session(session, base, {});
  RefinementOptions refinement;
  refinement.settle = 1e-3;
  const auto [by_hand, status] = refined_by_hand(base, session, refinement);
  EXPECT_TRUE(status.settled);
  EXPECT_EQ(settled, by_hand);
  EXPECT_GT((settled - converged).cwiseAbs().maxCoeff(), 0.0) << "the settle test should stop earlier than the energy test";
}

TEST(Session, ARefinedStageReplaysAsRefinedAndOlderSessionsAsThePapersMethod) {
  const test::TempDir dir;
  Session session = demo_session();
  const Mesh base = cli::load_session_mesh(session);
  const Eigen::MatrixXd paper = cli::replay_session(session, base, {});
  session.current.refine = true;
  const Eigen::MatrixXd refined = cli::replay_session(session, base, {});
  EXPECT_GT((refined - paper).cwiseAbs().maxCoeff(), 1e-4);
  // A fresh deformer refined by hand from the paper's result gives the same bits.
  const auto [by_hand, status] = refined_by_hand(base, session, RefinementOptions{});
  EXPECT_TRUE(status.converged);
  EXPECT_EQ(refined, by_hand);
  // Written before refinement existed: no "refine" member, read as the paper's method.
  auto old = cli::to_json(session);
  old["current"].erase("refine");
  const std::string text = old.dump(1);
  dir.write("old.json", text);
  EXPECT_FALSE(cli::read_session(dir.file("old.json")).current.refine);
}

TEST(Session, ReplayEqualsTheDeformerBitForBit) {
  const Session session = demo_session();
  const Mesh base = cli::load_session_mesh(session);
  Deformer deformer(base, session.current.constraints());
  Eigen::MatrixXd expected;
  deformer.deform(session.current.transforms(), expected);
  EXPECT_EQ(cli::replay_session(session, base, {}), expected);
  EXPECT_GT((expected - base.positions).cwiseAbs().maxCoeff(), 0.01);
}

TEST(Session, AppliedStagesBecomeTheRestShapeInOrder) {
  Session session = demo_session();
  const Mesh base = cli::load_session_mesh(session);
  session.applied.push_back(session.current);
  Mesh rest = base;
  {
    Deformer first(rest, session.current.constraints());
    first.deform(session.current.transforms(), rest.positions);
  }
  Deformer second(rest, session.current.constraints());
  Eigen::MatrixXd expected;
  second.deform(session.current.transforms(), expected);
  EXPECT_EQ(cli::replay_session(session, base, {}), expected);
  session.current.handles.clear();
  EXPECT_EQ(cli::replay_session(session, base, {}), rest.positions);  // nothing current: the applied rest
}

TEST(Session, ReplayRefusesABrokenBaseMeshEvenWithNothingToDeform) {
  Session session = demo_session();
  Mesh base = cli::load_session_mesh(session);
  base.triangles(3, 1) = static_cast<int>(base.vertex_count());
  session.current.handles.clear();
  try {
    cli::replay_session(session, base, {});
    ADD_FAILURE() << "replayed on a mesh with an index out of range";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("triangle 3 corner 1 has vertex index"), std::string::npos) << error.what();
  }
}

// Expects read_session (and the mesh check) to fail with `file:line` and the fragment.
void expect_session_error(const test::TempDir& dir, const std::string& text, std::size_t line, const std::string& fragment) {
  dir.write("bad.json", text);
  try {
    cli::SessionSource source;
    const Session session = cli::read_session(dir.file("bad.json"), &source);
    cli::check_session_against_mesh(session, 100, source);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("bad.json:" + std::to_string(line) + ":"), std::string::npos) << message;
    EXPECT_NE(message.find(fragment), std::string::npos) << message;
  }
}

TEST(Session, MalformedSessionsNameTheLineAndTheProblem) {
  const test::TempDir dir;
  const std::string head = "{\n \"format\": \"hdeform-session\",\n \"version\": 1,\n \"mesh\": \"shape:cactus\",\n";
  expect_session_error(dir, "{\n \"format\": \"hdeform-session\",\n \"version\": 1,\n \"mesh\": \"x\"\n \"current\": {}\n}\n", 5, "not valid JSON");
  expect_session_error(dir, "{\n \"format\": \"something-else\"\n}\n", 2, "not an hdeform session");
  expect_session_error(dir, head + " \"current\": {\n  \"fixed\": [1, 2, \"three\"]\n }\n}\n", 6, "expected a vertex index");
  expect_session_error(dir, head + " \"current\": {\n  \"fixed\": [1, 2,\n   -3]\n }\n}\n", 7, "out of range");
  expect_session_error(dir, head + " \"current\": {\n  \"fixed\": [1, 2,\n   300]\n }\n}\n", 7, "vertex 300 out of range (the mesh has 100 vertices)");
  expect_session_error(dir,
                       head + " \"current\": {\n  \"fixed\": [5],\n  \"handles\": [\n   {\"vertices\": [6,\n 5],\n    \"transform\": {\"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0]}}\n  ]\n }\n}\n",
                       9, "is both fixed and in handle 1");
  const std::string identity = "\"transform\": {\"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0]}";
  expect_session_error(dir, head + " \"current\": {\n  \"fixed\": [5, 7,\n   5]\n }\n}\n", 7, "current/fixed/2: vertex 5 listed twice");
  expect_session_error(dir,
                       head + " \"current\": {\n  \"handles\": [\n   {\"vertices\": [6, 8], " + identity + "},\n   {\"vertices\": [9,\n 8], " +
                           identity + "}\n  ]\n }\n}\n",
                       9, "current/handles/1/vertices/1: vertex 8 is both in handle 1 and in handle 2");
  expect_session_error(dir,
                       head + " \"current\": {\n  \"handles\": [\n   {\"vertices\": [6],\n    \"transform\": {\"matrix\": [1,0,0,0, 0,1,0,0, 0,0,0,0]}}\n  ]\n }\n}\n",
                       8, "singular");
  expect_session_error(dir,
                       head + " \"current\": {\n  \"handles\": [\n   {\"vertices\": [6],\n    \"transform\": {\"pose\": {\"pivot\": [0,0,0], \"axis\": [0,0,0], \"angle\": 1, \"scale\": 1, \"shift\": [0,0,0]}}}\n  ]\n }\n}\n",
                       8, "axis is zero");
  expect_session_error(dir, head + " \"current\": {\n  \"handles\": [\n   {\"vertices\": []}\n  ]\n }\n}\n", 7, "at least one vertex");
  expect_session_error(dir, head + " \"applied\": 3,\n \"current\": {}\n}\n", 5, "expected a list of stages");
  expect_session_error(dir, head + " \"current\": {\n  \"refine\": true,\n  \"refine_settle\": -1\n }\n}\n", 7, "below 1");
}

// Loading a session's mesh from its file checks the session's lists against that mesh, so that
// an editor opening the file says which line does not fit (not just "session").
TEST(Session, LoadingTheMeshFromTheFileChecksTheListsAgainstIt) {
  const test::TempDir dir;
  dir.write("big.json", "{\n \"format\": \"hdeform-session\",\n \"version\": 1,\n \"mesh\": \"shape:cactus:24\",\n \"current\": {\n  \"fixed\": [1,\n   99999999]\n }\n}\n");
  cli::SessionSource source;
  const Session session = cli::read_session(dir.file("big.json"), &source);
  try {
    cli::load_session_mesh(session, &source);
    ADD_FAILURE() << "a vertex out of range was taken";
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("big.json:7: /current/fixed/1: vertex 99999999 out of range"), std::string::npos) << message;
  }
  EXPECT_EQ(cli::load_session_mesh(session).vertex_count(), make_shape(ShapeKind::Cactus, 24).mesh.vertex_count());  // no file, no check
}

// A session says where it was solved; its replay solves there, whatever the size, and a file
// from before multiresolution (no "resolution") replays exactly.
TEST(Session, ReplaySolvesWhereTheSessionSays) {
  const test::TempDir dir;
  Session session = demo_session();
  const Mesh base = cli::load_session_mesh(session);
  session.resolution = Resolution::Multiresolution;
  session.base_vertices = base.vertex_count() / 4;
  cli::write_session(dir.file("multi.json"), session);
  const Session back = cli::read_session(dir.file("multi.json"));
  EXPECT_EQ(back, session);
  Session other = back;
  other.base_vertices += 1;
  EXPECT_FALSE(other == session);  // the base's size is part of it

  DeformerOptions options;
  options.resolution = Resolution::Multiresolution;
  options.base_vertices = session.base_vertices;
  Deformer deformer(base, session.current.constraints(), options);
  ASSERT_LT(deformer.solved_mesh().vertex_count(), base.vertex_count());
  Eigen::MatrixXd expected;
  deformer.deform(session.current.transforms(), expected);
  DeformerOptions exact;
  exact.resolution = Resolution::Exact;  // the session's resolution replaces what the caller asks
  EXPECT_EQ(cli::replay_session(back, base, exact), expected);

  nlohmann::json old = cli::to_json(demo_session());
  old.erase("resolution");
  dir.write("old.json", old.dump(1));
  EXPECT_EQ(cli::read_session(dir.file("old.json")).resolution, Resolution::Exact);
  const std::string head = "{\n \"format\": \"hdeform-session\",\n \"version\": 1,\n \"mesh\": \"shape:cactus\",\n \"current\": {},\n";
  expect_session_error(dir, head + " \"resolution\": \"coarse\"\n}\n", 6, "expected \"exact\", \"multiresolution\" or \"automatic\"");
  expect_session_error(dir, head + " \"resolution\": \"multiresolution\",\n \"base_vertices\": 2\n}\n", 7, "at least 4");
}

// A session solved with single-precision factors says so, and its replay solves alike (the same
// bits as a Deformer asked for single precision), whatever the caller asks; one that says
// nothing solves as the caller asks.
TEST(Session, ReplayStoresTheFactorsAsTheSessionSays) {
  const test::TempDir dir;
  Session session = demo_session();
  session.resolution = Resolution::Exact;
  const Mesh base = cli::load_session_mesh(session);
  const nlohmann::json unstated = cli::to_json(session);
  EXPECT_FALSE(unstated.contains("precision"));  // files from before stay as they were
  session.precision = FactorPrecision::Single;
  cli::write_session(dir.file("single.json"), session);
  const Session back = cli::read_session(dir.file("single.json"));
  EXPECT_EQ(back.precision, FactorPrecision::Single);
  EXPECT_EQ(back, session);
  Session in_double = back;
  in_double.precision = FactorPrecision::Double;
  EXPECT_FALSE(in_double == session);

  DeformerOptions single;
  single.resolution = Resolution::Exact;
  single.precision = FactorPrecision::Single;
  Deformer deformer(base, session.current.constraints(), single);
  Eigen::MatrixXd expected;
  deformer.deform(session.current.transforms(), expected);
  DeformerOptions asked;  // double: the session's precision replaces it
  EXPECT_EQ(cli::replay_session(back, base, asked), expected);
  Session unsaid = back;
  unsaid.precision.reset();
  EXPECT_NE(cli::replay_session(unsaid, base, asked), expected);  // solved in double: other last bits
  EXPECT_EQ(cli::replay_session(unsaid, base, single), expected);

  const std::string head = "{\n \"format\": \"hdeform-session\",\n \"version\": 1,\n \"mesh\": \"shape:cactus\",\n \"current\": {},\n";
  expect_session_error(dir, head + " \"precision\": \"half\"\n}\n", 6, "expected \"double\" or \"single\"");
}

}  // namespace
}  // namespace hdeform

// The editor under Xvfb where trust is at stake: a bad file explained in the window, typed values
// through undo, redo and kill -9, SIGTERM and the restore prompt, the gizmo's constraint, transfer
// mode's markers after kill -9.
#include "editor_gui_harness.h"

namespace hdeform {
namespace {

using namespace gui_test;


TEST_F(EditorGui, ABadMeshOnTheCommandLineIsExplainedInTheWindowAndOpenRecovers) {
  {
    std::ofstream broken(dir.file("broken.obj"));
    broken << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  }
  Editor editor({dir.file("broken.obj").string(), "--size", std::to_string(kWidth) + "x" + std::to_string(kHeight), "--recovery-file",
                 dir.file("recovery.json").string(), "--restore", "no", "--screenshot-dir", dir.path().string(), "--validation"});
  const json dialog = editor.wait_for("dialog");
  EXPECT_EQ(dialog.value("title", ""), "Could not open");
  EXPECT_EQ(dialog.value("message", ""), dir.file("broken.obj").string() + ":3: face index 7 out of range (the file has 2 vertices)");
  ASSERT_NO_FATAL_FAILURE(find_window());
  std::this_thread::sleep_for(500ms);
  const engine::Pixels shown = window_picture(editor);
  EXPECT_GT(title_bar_pixels(shown), 1000) << "no dialog in the middle of the window";
  // Enter: Open another, its box focused and holding the folder; type a good file.
  const auto before = editor.event_count();
  press("Return");
  std::this_thread::sleep_for(300ms);
  xdotool("type --delay 40 " + dir.file("cactus.obj").string());
  press("Return");
  const json opened = editor.wait_for("opened", 60s, before);
  EXPECT_EQ(opened.value("mesh", ""), dir.file("cactus.obj").string());
  std::this_thread::sleep_for(500ms);
  EXPECT_LT(title_bar_pixels(window_picture(editor)), 50) << "the dialog stayed";
  quit(editor);
}

// Double click Move X, type a value, Enter: the mesh follows, Ctrl+Z takes it back, Ctrl+Shift+Z
// brings it again (never an older state), and kill -9 finds it in the recovery file. The digits
// typed into the fields never reach the shortcuts (1 would pick the paint tool, 0 reset the pose).
TEST_F(EditorGui, TypedValuesAreUndoableStepsAndReachTheRecoveryFile) {
  const auto recovery = dir.file("recovery.json");
  Editor editor(shape_arguments("shape:cactus", "no"));
  ASSERT_NO_FATAL_FAILURE(until_ready(editor));
  const PoseFieldPixels fields = pose_field_pixels(editor);
  // The panel's fields are single precision.
  const auto shift_x = [](const cli::Session& session) { return static_cast<float>(session.current.handles.at(0).transform.shift.x()); };
  move_to(fields.move_x);
  xdotool("click --repeat 2 --delay 60 1");
  xdotool("type --delay 60 0.1");
  press("Return");
  const auto moved = recovery_holding(recovery, [&](const cli::Session& s) { return shift_x(s) == 0.1f; });
  ASSERT_TRUE(moved);
  move_to({kWidth * 0.75f, kHeight * 0.5f});
  press("ctrl+z");
  ASSERT_TRUE(recovery_holding(recovery, [&](const cli::Session& s) { return shift_x(s) == 0.0f; }));
  press("ctrl+shift+z");
  ASSERT_TRUE(recovery_holding(recovery, [&](const cli::Session& s) { return shift_x(s) == 0.1f; }));
  move_to(fields.angle);
  xdotool("click --repeat 2 --delay 60 1");
  xdotool("type --delay 60 10");
  press("Return");
  const auto typed = recovery_holding(recovery, [&](const cli::Session& s) { return s.current.handles.at(0).transform.angle != 0.0; });
  ASSERT_TRUE(typed);
  EXPECT_NEAR(typed->current.handles[0].transform.angle, 10.0 * std::numbers::pi / 180.0, 1e-6);
  EXPECT_EQ(shift_x(*typed), 0.1f) << "the 0 typed into the angle reset the pose";
  EXPECT_EQ(typed->current.handles[0].vertices, moved->current.handles[0].vertices);
  EXPECT_EQ(typed->current.fixed, moved->current.fixed);
  editor.kill_now();
  const cli::Session after_kill = cli::read_session(recovery);
  EXPECT_EQ(after_kill.current, typed->current);
}

// SIGTERM keeps the session for the next start, which names it and, declined, opens what the
// command line asked for, keeping the recovered session in a file of its own.
TEST_F(EditorGui, AfterSigtermTheNextStartOffersTheSessionBesideTheRequestedMesh) {
  const auto recovery = dir.file("recovery.json");
  const std::vector<std::string> common{"--size", std::to_string(kWidth) + "x" + std::to_string(kHeight), "--recovery-file", recovery.string(),
                                        "--restore", "ask", "--screenshot-dir", dir.path().string(), "--validation"};
  std::vector<std::string> first{"shape:cactus"}, second{"shape:bar"};
  first.insert(first.end(), common.begin(), common.end());
  second.insert(second.end(), common.begin(), common.end());
  cli::Session moved;
  {
    Editor editor(first);
    editor.wait_for("opened");
    ASSERT_NO_FATAL_FAILURE(find_window());
    // As in the typed-values test: type once the set-up is done (under ThreadSanitizer its frames
    // are slow enough to split a double click).
    EXPECT_EQ(editor.settled_solver_state(), "ready");
    move_to(pose_field_pixels(editor).move_x);
    xdotool("click --repeat 2 --delay 60 1");
    xdotool("type --delay 60 0.2");  // still in the field, not committed
    // Applied and in the recovery file (the periodic write), though never committed: the signal
    // must keep that file for the next start rather than remove it as a clean exit does.
    ASSERT_TRUE(recovery_holding(recovery, [](const cli::Session& s) {
      return static_cast<float>(s.current.handles.at(0).transform.shift.x()) == 0.2f;
    }));
    const auto before = editor.event_count();
    editor.send(SIGTERM);
    const json signal = editor.wait_for("signal", 30s, before);
    EXPECT_EQ(signal.value("signal", ""), "SIGTERM");
    EXPECT_EQ(signal.value("recovery", ""), recovery.string());
    EXPECT_EQ(editor.wait_exit(), 128 + SIGTERM);
    moved = cli::read_session(recovery);
    EXPECT_FLOAT_EQ(static_cast<float>(moved.current.handles.at(0).transform.shift.x()), 0.2f);
  }
  Editor editor(second);
  const json prompt = editor.wait_for("restore prompt");
  EXPECT_EQ(prompt.value("mesh", ""), "shape:cactus");
  EXPECT_EQ(prompt.value("requested", ""), "shape:bar");
  EXPECT_EQ(prompt.value("holds", "").substr(0, 27), "1 handle (193 vertices, mov");
  ASSERT_NO_FATAL_FAILURE(find_window());
  std::this_thread::sleep_for(300ms);
  EXPECT_GT(title_bar_pixels(window_picture(editor)), 1000) << "no prompt in the middle of the window";
  press("Escape");  // open the requested mesh
  const json kept = editor.wait_for("recovery kept");
  const json opened = editor.wait_for("opened");
  EXPECT_EQ(opened.value("mesh", ""), "shape:bar");
  EXPECT_EQ(cli::read_session(kept.value("path", std::string())).current, moved.current);
  quit(editor);
  EXPECT_FALSE(std::filesystem::exists(recovery)) << "a clean exit removes its own recovery file";
  EXPECT_TRUE(std::filesystem::exists(kept.value("path", std::string()))) << "but never the one kept";
}

// A drag on the gizmo's x axis moves the handle along x and nothing else, about as far as the
// cursor went along the axis on screen.
TEST_F(EditorGui, DraggingTheGizmosXAxisMovesTheHandleAlongXOnly) {
  const auto recovery = dir.file("recovery.json");
  Editor editor(shape_arguments("shape:cactus:24", "no"));
  ASSERT_NO_FATAL_FAILURE(until_ready(editor));
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
  for (const int v : shape.demo_constraints.handles[0]) pivot += shape.mesh.positions.row(v).transpose();
  pivot /= static_cast<double>(shape.demo_constraints.handles[0].size());
  const double length = 0.08 * 2.0 * engine::Bounds::of(shape.mesh.positions).radius();  // the editor's gizmo: 8% of the scene
  const Eigen::Vector2f grab = view.pixel(pivot + 0.6 * length * Eigen::Vector3d::UnitX());
  const Eigen::Vector2f release = view.pixel(pivot + 1.6 * length * Eigen::Vector3d::UnitX());
  ASSERT_GT((release - grab).norm(), 20.0f) << "the x axis is seen end-on from the default view";
  press("g");
  // Off the axis's screen line by a few pixels on the way: the constraint holds the move to x.
  drag(grab, release + Eigen::Vector2f(0.0f, 6.0f), 10);
  const auto moved = recovery_holding(recovery, [](const cli::Session& s) { return s.current.handles.at(0).transform.shift.x() != 0.0; });
  ASSERT_TRUE(moved);
  const Eigen::Vector3d shift = moved->current.handles[0].transform.shift;
  EXPECT_EQ(shift.y(), 0.0);
  EXPECT_EQ(shift.z(), 0.0);
  EXPECT_NEAR(shift.x(), length, 0.35 * length);
  quit_discarding_changes(editor);
}

// Marker pairs clicked in transfer mode, never saved, survive kill -9: the next start restores
// them on the same meshes.
TEST_F(EditorGui, TransferModeMarkersSurviveKillNine) {
  const std::vector<std::string> arguments{"--size", std::to_string(kWidth) + "x" + std::to_string(kHeight), "--recovery-file",
                                           dir.file("recovery.json").string(), "--validation", "--transfer-source", dir.file("cactus.obj").string(),
                                           "--transfer-target", dir.file("cactus.obj").string()};
  const float view_width = (kWidth - kPanelWidth) / 2.0f;
  {
    std::vector<std::string> first = arguments;
    first.insert(first.end(), {"--restore", "no"});
    Editor editor(first);
    editor.wait_for("transfer opened");
    ASSERT_NO_FATAL_FAILURE(find_window());
    const auto before = editor.event_count();
    move_to({kPanelWidth + 0.5f * view_width, kHeight * 0.55f});  // the trunk, in each view
    xdotool("click 1");
    std::this_thread::sleep_for(250ms);
    move_to({kPanelWidth + 1.5f * view_width, kHeight * 0.55f});
    xdotool("click 1");
    editor.wait_for("marker added", 30s, before);
    const json written = editor.wait_for("transfer recovery", 30s, before);
    EXPECT_EQ(written.value("markers", -1), 1);
    editor.kill_now();
  }
  ASSERT_TRUE(std::filesystem::exists(dir.file("recovery-transfer.json")));
  const cli::TransferState kept = cli::read_transfer_state(dir.file("recovery-transfer.json"));
  ASSERT_EQ(kept.markers.size(), 1u);
  std::vector<std::string> second = arguments;
  second.insert(second.end(), {"--restore", "yes"});
  Editor editor(second);
  const json restored = editor.wait_for("transfer restored");
  EXPECT_EQ(restored.value("markers", -1), 1);
  ASSERT_NO_FATAL_FAILURE(find_window());
  // The restored pair was never saved: Quit asks, and the recovery file stays until the answer.
  const auto before_quit = editor.event_count();
  press("ctrl+q");
  const json asked = editor.wait_for("dialog", 30s, before_quit);
  EXPECT_EQ(asked.value("markers", ""), "1 marker pair (never saved)");
  EXPECT_TRUE(std::filesystem::exists(dir.file("recovery-transfer.json")));
  press("Escape");
  EXPECT_EQ(editor.wait_for("dialog closed", 30s, before_quit).value("choice", ""), "cancel");
  EXPECT_TRUE(std::filesystem::exists(dir.file("recovery-transfer.json")));
  quit_discarding_changes(editor);
  EXPECT_FALSE(std::filesystem::exists(dir.file("recovery-transfer.json"))) << "a clean exit removes it";
}

TEST_F(EditorGui, TransferModeMarkersUndoSaveAndCompute) {
  // The cactus as both source and target, one bent pose: clicking the same vertex in both views
  // makes a pair of identical vertices.
  Deformer deformer(rest, shape.demo_constraints);
  Eigen::MatrixXd bent;
  deformer.deform(std::span(&shape.demo_transform, 1), bent);
  write_obj(dir.file("bent.obj"), Mesh{bent, rest.triangles});
  const std::string markers = dir.file("markers.txt").string();
  Editor editor({"--size", std::to_string(kWidth) + "x" + std::to_string(kHeight), "--recovery-file", dir.file("recovery.json").string(),
                 "--restore", "no", "--validation", "--transfer-source", dir.file("cactus.obj").string(), "--transfer-target",
                 dir.file("cactus.obj").string(), "--source-pose", dir.file("bent.obj").string(), "--markers", markers});
  editor.wait_for("transfer opened");
  ASSERT_NO_FATAL_FAILURE(find_window());

  // The two views share the window right of the panel, each framed like the offscreen default.
  const float view_width = (kWidth - kPanelWidth) / 2.0f;
  const auto bounds = engine::Bounds::of(rest.positions);
  const auto camera = engine::Camera::three_quarter_front(bounds, engine::UpAxis::Z, view_width / kHeight);
  auto pixel = [&](int side, int vertex) {
    const Eigen::Vector4f clip = camera.view_projection(view_width / kHeight) * Eigen::Vector4f(rest.positions.row(vertex).transpose().cast<float>().homogeneous());
    return Eigen::Vector2f(kPanelWidth + side * view_width + (clip.x() / clip.w() * 0.5f + 0.5f) * view_width, (clip.y() / clip.w() * 0.5f + 0.5f) * kHeight);
  };
  // Four vertices facing the camera, far apart: the tips of the arms, the top, the trunk.
  View side_view{camera};
  std::vector<int> aimed;
  for (const auto& region : {shape.demo_constraints.handles[0], shape.demo_constraints.fixed}) aimed.push_back(facing_vertex(rest, region, side_view));
  for (const double height : {0.95, 0.6}) {
    std::vector<int> band;
    const double low = rest.positions.col(2).minCoeff(), high = rest.positions.col(2).maxCoeff();
    for (Eigen::Index v = 0; v < rest.vertex_count(); ++v) {
      if (std::abs(rest.positions(v, 2) - (low + height * (high - low))) < 0.02 * (high - low)) band.push_back(static_cast<int>(v));
    }
    aimed.push_back(facing_vertex(rest, band, side_view));
  }
  for (const int vertex : aimed) {
    const auto before = editor.event_count();
    move_to(pixel(0, vertex));
    xdotool("click 1");
    std::this_thread::sleep_for(250ms);
    move_to(pixel(1, vertex));
    xdotool("click 1");
    const json added = editor.wait_for("marker added", 30s, before);
    EXPECT_EQ(added["source"], added["target"]) << "the same point of the same mesh in both views";
    EXPECT_LT((rest.positions.row(added["source"].get<int>()) - rest.positions.row(vertex)).norm(), 0.05 * (bounds.max - bounds.min).norm());
  }
  auto saved_markers = [&] {
    const auto before = editor.event_count();
    press("ctrl+s");
    editor.wait_for("markers saved", 30s, before);
    return read_marker_pairs(markers, SourceColumn::First, rest.vertex_count(), rest.vertex_count());
  };
  const MarkerPairs four = saved_markers();
  ASSERT_EQ(four.size(), 4u);
  press("ctrl+z");
  const MarkerPairs three = saved_markers();
  ASSERT_EQ(three.size(), 3u);
  EXPECT_EQ(three.source, std::vector<int>(four.source.begin(), four.source.begin() + 3));
  press("ctrl+shift+z");
  EXPECT_EQ(saved_markers().source, four.source);

  const auto before = editor.event_count();
  press("F5");
  const json computed = editor.wait_for("transfer computed", 60s, before);
  EXPECT_EQ(computed["markers"], 4);
  EXPECT_EQ(computed["poses"], 1);
  EXPECT_EQ(computed["factorizations"], 3);  // the coordinates on each mesh and the target's Poisson system
  EXPECT_EQ(computed["mismatched_triangles"], 0);
  quit(editor);
}

}  // namespace
}  // namespace hdeform

// What the screen shows is what is saved and what `edit` computes: the editor's reproductions of
// the refinement that stalled on a sheared shape (a drag reversed past the rest shape, a reset
// then a drag another way, an undo to an earlier pose, a typed move then its opposite), each
// followed by Ctrl+S; and nothing is lost on Open, Quit or a save that cannot be written.
#include "editor_gui_harness.h"

#include <sys/stat.h>

namespace hdeform {
namespace {

using namespace gui_test;

// The built-in cylinder as a user's file, its demo's sink and handle as vertex lists.
class ShownShapeGui : public EditorGui {
 protected:
  void SetUp() override {
    EditorGui::SetUp();
    if (IsSkipped()) return;
    cylinder = make_shape(ShapeKind::Cylinder, 24);
    write_obj(dir.file("cylinder.obj"), cylinder.mesh);
    rest = read_obj(dir.file("cylinder.obj"));
    std::string fixed, handle;
    for (const int v : cylinder.demo_constraints.fixed) fixed += std::to_string(v) + "\n";
    for (const int v : cylinder.demo_constraints.handles[0]) handle += std::to_string(v) + "\n";
    dir.write("fixed.txt", fixed);
    dir.write("handle.txt", handle);
    view.camera = engine::Camera::three_quarter_front(engine::Bounds::of(rest.positions), engine::UpAxis::Z, static_cast<float>(kWidth) / kHeight,
                                                      kPanelWidth / static_cast<float>(kWidth));
    diagonal = bounding_box_diagonal(rest.positions);
  }

  std::vector<std::string> cylinder_arguments() const {
    return {dir.file("cylinder.obj").string(), "--fixed", dir.file("fixed.txt").string(), "--handle", dir.file("handle.txt").string(),
            "--size", std::to_string(kWidth) + "x" + std::to_string(kHeight), "--recovery-file", dir.file("recovery.json").string(),
            "--restore", "no", "--output", dir.file("saved.obj").string(), "--validation"};
  }

  // Where a grab starts: on the cylinder's facing side, half way up, away from the gizmo (a drag
  // that starts on one of its parts is held to that axis or plane).
  Eigen::Vector2f grab_pixel() const {
    std::vector<int> middle;
    const double low = rest.positions.col(2).minCoeff(), high = rest.positions.col(2).maxCoeff();
    for (Eigen::Index v = 0; v < rest.vertex_count(); ++v) {
      if (std::abs(rest.positions(v, 2) - 0.5 * (low + high)) < 0.05 * (high - low)) middle.push_back(static_cast<int>(v));
    }
    return view.pixel(rest.positions.row(facing_vertex(rest, middle, view)).transpose());
  }

  // Until the refinement of the newest input has settled: its announcement. A pause within an
  // input (a slow machine) may settle an earlier pose first: the last announcement counts, once
  // a second has passed without another.
  json settled_after(Editor& editor, std::size_t before) {
    EXPECT_FALSE(editor.wait_for("refined", 90s, before).is_null());
    for (std::size_t seen = editor.event_count();;) {
      std::this_thread::sleep_for(1s);
      const std::size_t now = editor.event_count();
      if (now == seen) break;
      seen = now;
    }
    const auto all = editor.events_named("refined", before);
    return all.empty() ? json() : all.back();
  }

  // Saves, and checks the one truth: the saved shape is the one on screen (the same digest of the
  // same doubles), `edit --session` writes the same file byte for byte, and `edit --refine auto`
  // with the editor's settle test, given the pose as a matrix, gives the same shape and energies.
  void expect_screen_saved_and_batch_agree(Editor& editor, const json& refined, const std::string& what) {
    SCOPED_TRACE(what);
    const auto before = editor.event_count();
    press("ctrl+s");
    const json saved = editor.wait_for("saved", 90s, before);
    ASSERT_FALSE(saved.is_null());
    EXPECT_EQ(saved.value("positions_digest", std::string("saved")), refined.value("positions_digest", std::string("shown")))
        << "the saved positions are not the ones on screen";
    const std::string session_path = saved["session"].get<std::string>();
    const auto [replay_status, replay_output] = shell(std::string(HDEFORM_EXECUTABLE) + " edit --session " + session_path + " --out " +
                                                      dir.file("replayed.obj").string() + " --quiet 2>&1");
    ASSERT_EQ(replay_status, 0) << replay_output;
    EXPECT_EQ(shell("cmp " + dir.file("replayed.obj").string() + " " + saved["obj"].get<std::string>()).first, 0)
        << "edit --session does not write the saved file";

    const cli::Session session = cli::read_session(session_path);
    ASSERT_EQ(session.current.handles.size(), 1u);
    EXPECT_TRUE(session.current.refine);
    EXPECT_EQ(session.current.refine_settle, kEditorSettle);
    const Eigen::Matrix<double, 3, 4> affine = session.current.handles[0].transform.affine();
    std::string matrix;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) {
        char number[40];
        std::snprintf(number, sizeof number, "%.17g ", affine(r, c));
        matrix += number;
      }
      matrix += "\n";
    }
    dir.write("pose.txt", matrix);
    const auto [batch_status, batch_output] =
        shell(std::string(HDEFORM_EXECUTABLE) + " edit --mesh " + dir.file("cylinder.obj").string() + " --fixed " + dir.file("fixed.txt").string() +
              " --handle " + dir.file("handle.txt").string() + " --transform " + dir.file("pose.txt").string() +
              " --refine auto --refine-settle " + std::to_string(kEditorSettle) + " --out " + dir.file("batch.obj").string() + " --quiet");
    ASSERT_EQ(batch_status, 0) << batch_output;
    const json report = json::parse(batch_output);
    const Eigen::MatrixXd batch = read_obj(dir.file("batch.obj")).positions;
    const Eigen::MatrixXd shown = read_obj(saved["obj"].get<std::string>()).positions;
    EXPECT_LE((batch - shown).rowwise().norm().maxCoeff(), 1e-6 * diagonal);
    const double energy = refined.value("energy", -1.0), unrefined = refined.value("unrefined_energy", -1.0);
    EXPECT_NEAR(report["refine"]["energy"].get<double>(), energy, 1e-9 * std::max(1.0, energy));
    EXPECT_NEAR(report["refine"]["unrefined_energy"].get<double>(), unrefined, 1e-9 * std::max(1.0, unrefined));
    EXPECT_EQ(report["refine"]["last_step_iterations"].get<int>(), refined.value("iterations", -1));
  }

  // A grab from `from` to `to` (offsets from grab_pixel()), then until it has settled.
  json drag_and_settle(Editor& editor, const Eigen::Vector2f& from, const Eigen::Vector2f& to, int steps) {
    const Eigen::Vector2f start = grab_pixel();
    const auto before = editor.event_count();
    drag(start + from, start + to, steps);
    return settled_after(editor, before);
  }

  Shape cylinder;
  double diagonal = 1.0;
};

TEST_F(ShownShapeGui, ADragReversedPastTheRestShapeSettlesToWhatIsSaved) {
  Editor editor(cylinder_arguments());
  ASSERT_NO_FATAL_FAILURE(until_ready(editor));
  press("g");
  const Eigen::Vector2f start = grab_pixel();
  const json right = drag_and_settle(editor, Eigen::Vector2f::Zero(), Eigen::Vector2f(120.0f, 0.0f), 12);
  EXPECT_GT(right.value("iterations", 0), 3);
  // Back left past the rest position at a normal speed: 100 ms between moves.
  const auto before = editor.event_count();
  move_to(start + Eigen::Vector2f(120.0f, 0.0f));
  xdotool("mousedown 1");
  std::this_thread::sleep_for(150ms);
  for (int k = 1; k <= 24; ++k) {
    xdotool("mousemove --window " + window + " " + at(start + Eigen::Vector2f(120.0f - 10.0f * static_cast<float>(k), 0.0f)));
    std::this_thread::sleep_for(100ms);
  }
  xdotool("mouseup 1");
  const json left = settled_after(editor, before);
  EXPECT_GT(left.value("iterations", 0), 3) << "the stall: one iteration, then 'settled' on the paper's sheared shape";
  EXPECT_LT(left.value("energy", 1.0), 0.8 * left.value("unrefined_energy", 0.0));
  ASSERT_NO_FATAL_FAILURE(expect_screen_saved_and_batch_agree(editor, left, "reversed drag"));
  quit(editor);
}

TEST_F(ShownShapeGui, AResetThenADragAnotherWayAndAnUndoSettleToWhatIsSaved) {
  Editor editor(cylinder_arguments());
  ASSERT_NO_FATAL_FAILURE(until_ready(editor));
  press("g");
  const json first = drag_and_settle(editor, Eigen::Vector2f::Zero(), Eigen::Vector2f(110.0f, 0.0f), 10);
  auto before = editor.event_count();
  press("0");  // reset the handles
  const json reset = settled_after(editor, before);
  EXPECT_EQ(reset.value("iterations", -1), 0);
  EXPECT_EQ(reset.value("energy", -1.0), 0.0);
  const json other = drag_and_settle(editor, Eigen::Vector2f::Zero(), Eigen::Vector2f(0.0f, 70.0f), 10);  // down: another way
  EXPECT_GT(other.value("iterations", 0), 3);
  ASSERT_NO_FATAL_FAILURE(expect_screen_saved_and_batch_agree(editor, other, "reset, then a drag another way"));
  // Undo to the reset, then to the first drag: the first drag's shape again, bit for bit.
  before = editor.event_count();
  press("ctrl+z");
  settled_after(editor, before);
  before = editor.event_count();
  press("ctrl+z");
  const json undone = settled_after(editor, before);
  EXPECT_EQ(undone.value("positions_digest", std::string("undone")), first.value("positions_digest", std::string("first")));
  ASSERT_NO_FATAL_FAILURE(expect_screen_saved_and_batch_agree(editor, undone, "undo to the first drag"));
  quit(editor);
}

TEST_F(ShownShapeGui, ATypedMoveThenItsOppositeSettleToWhatIsSaved) {
  Editor editor(cylinder_arguments());
  ASSERT_NO_FATAL_FAILURE(until_ready(editor));
  for (const char* value : {"0.5", "-0.5"}) {
    // Where the panel puts the field now (the status line's length moves it).
    const auto announced = editor.events_named("pose fields");
    ASSERT_FALSE(announced.empty());
    const json& fields = announced.back();
    const auto before = editor.event_count();
    move_to({fields.value("x", 0.0f) + 0.15f * fields.value("width", 0.0f), fields.value("y", 0.0f) + 0.4f * fields.value("row", 0.0f)});
    xdotool("click --repeat 2 --delay 60 1");
    xdotool(std::string("type --delay 60 -- ") + value);
    press("Return");
    const json typed = settled_after(editor, before);
    EXPECT_GT(typed.value("iterations", 0), 3) << value;
    move_to({kWidth * 0.75f, kHeight * 0.5f});
    ASSERT_NO_FATAL_FAILURE(expect_screen_saved_and_batch_agree(editor, typed, std::string("typed Move x ") + value));
  }
  quit(editor);
}

// Refine turned on after a drag (the session started without it): the shape settles and Save
// writes it. The toggle once asked nothing new of the pipeline, which refined the shape on screen
// all the same, so the shown poses were never those asked for with refinement on: Save waited
// for ever ("once the shape settles").
TEST_F(ShownShapeGui, RefineTurnedOnAfterADragSettlesToWhatIsSaved) {
  auto arguments = cylinder_arguments();
  arguments.push_back("--no-refine");
  Editor editor(arguments);
  ASSERT_NO_FATAL_FAILURE(until_ready(editor));
  press("g");
  const Eigen::Vector2f start = grab_pixel();
  drag(start, start + Eigen::Vector2f(110.0f, 0.0f), 10);
  std::this_thread::sleep_for(500ms);
  EXPECT_TRUE(editor.events_named("refined").empty());
  // The checkbox is below the panel's fold: scroll to it.
  move_to({kPanelWidth * 0.5f, kHeight * 0.5f});
  for (int k = 0; k < 10; ++k) xdotool("click 5");
  std::this_thread::sleep_for(500ms);
  const auto toggles = editor.events_named("refine toggle");
  ASSERT_FALSE(toggles.empty());
  const json& toggle = toggles.back();
  const Eigen::Vector2f box(toggle.value("x", 0.0f) + 0.5f * toggle.value("height", 0.0f), toggle.value("y", 0.0f) + 0.5f * toggle.value("height", 0.0f));
  ASSERT_GT(box.y(), 0.0f);
  ASSERT_LT(box.y(), kHeight - 150.0f) << "the checkbox is not in view (the footer covers the last 150 pixels or so)";
  const auto before = editor.event_count();
  move_to(box);
  xdotool("click 1");
  const json refined = settled_after(editor, before);
  EXPECT_GT(refined.value("iterations", 0), 3);
  move_to({kWidth * 0.75f, kHeight * 0.5f});
  ASSERT_NO_FATAL_FAILURE(expect_screen_saved_and_batch_agree(editor, refined, "refine turned on after a drag"));
  quit(editor);
}

// Ctrl+O over unsaved edits asks: Cancel keeps everything (the edit, undo, the recovery file),
// Discard opens the other mesh.
TEST_F(ShownShapeGui, OpeningOverUnsavedEditsAsksFirst) {
  Editor editor(cylinder_arguments());
  ASSERT_NO_FATAL_FAILURE(until_ready(editor));
  press("g");
  drag_and_settle(editor, Eigen::Vector2f::Zero(), Eigen::Vector2f(100.0f, 0.0f), 8);
  const auto moved = recovery_holding(dir.file("recovery.json"), [](const cli::Session& s) { return !s.current.handles.at(0).transform.shift.isZero(); });
  ASSERT_TRUE(moved);
  const auto open_cactus = [&] {
    const auto asked_at = editor.event_count();
    press("ctrl+o");
    std::this_thread::sleep_for(300ms);
    xdotool("key ctrl+a");
    xdotool("type --delay 30 " + dir.file("cactus.obj").string());
    press("Return");
    const json asked = editor.wait_for("dialog", 30s, asked_at);
    EXPECT_EQ(asked.value("title", ""), "Unsaved changes");
    EXPECT_EQ(asked.value("edits", ""), "the edits of cylinder.obj");
    return asked_at;
  };
  auto asked_at = open_cactus();
  press("Escape");
  EXPECT_EQ(editor.wait_for("dialog closed", 30s, asked_at).value("choice", ""), "cancel");
  std::this_thread::sleep_for(500ms);
  EXPECT_EQ(cli::read_session(dir.file("recovery.json")).mesh, moved->mesh) << "the recovery file still holds the cylinder";
  // The edit is still there: undo takes it back.
  press("ctrl+z");
  ASSERT_TRUE(recovery_holding(dir.file("recovery.json"), [](const cli::Session& session) { return session.current.handles.at(0).transform.shift.isZero(); }));
  press("ctrl+shift+z");
  ASSERT_TRUE(recovery_holding(dir.file("recovery.json"), [](const cli::Session& s) { return !s.current.handles.at(0).transform.shift.isZero(); }));
  asked_at = open_cactus();
  press("d");
  EXPECT_EQ(editor.wait_for("dialog closed", 30s, asked_at).value("choice", ""), "discard");
  const json opened = editor.wait_for("opened", 60s, asked_at);
  EXPECT_EQ(opened.value("mesh", ""), dir.file("cactus.obj").string());
  quit(editor);
}

// A save is written on a thread of its own (a scan's OBJ takes seconds) while the input that came
// after Ctrl+S waits: the file holds the state at Ctrl+S, what came next is neither lost nor
// counted as saved.
TEST_F(ShownShapeGui, InputAfterASaveIsKeptAndNotCountedAsSaved) {
  Editor editor(cylinder_arguments());
  ASSERT_NO_FATAL_FAILURE(until_ready(editor));
  press("g");
  drag_and_settle(editor, Eigen::Vector2f::Zero(), Eigen::Vector2f(100.0f, 0.0f), 8);
  const auto before = editor.event_count();
  xdotool("key ctrl+s key 0");  // save, and at once reset the handle
  const json saved = editor.wait_for("saved", 60s, before);
  ASSERT_FALSE(saved.is_null());
  EXPECT_FALSE(cli::read_session(saved["session"].get<std::string>()).current.handles.at(0).transform.shift.isZero()) << "the save holds the moved handle";
  ASSERT_TRUE(recovery_holding(dir.file("recovery.json"), [](const cli::Session& s) { return s.current.handles.at(0).transform.shift.isZero(); }))
      << "the reset after the save was lost";
  quit_discarding_changes(editor);  // asks first: the reset is not saved
}

// A save that cannot be written (a folder the user may not write) opens a dialog with the reason,
// says so as an `error` event, writes nothing, and keeps the edits. Run as an unprivileged user:
// root writes anywhere.
TEST_F(ShownShapeGui, ASaveIntoAReadOnlyFolderOpensADialogAndWritesNothing) {
  if (geteuid() != 0 && access("/", W_OK) == 0) GTEST_SKIP() << "cannot tell a read-only folder from this user";
  std::filesystem::create_directories(dir.file("read-only"));
  std::vector<std::string> arguments = cylinder_arguments();
  const auto output = std::find(arguments.begin(), arguments.end(), "--output");
  *(output + 1) = dir.file("read-only/saved.obj").string();
  std::optional<Editor> editor;
  if (geteuid() == 0) {
    // As root, the editor runs as `nobody` (setpriv), with the X server's cookie and the test's
    // folder open to it, and the folder it saves to closed to it.
    if (shell("command -v setpriv").first != 0) GTEST_SKIP() << "setpriv (util-linux) is not installed";
    std::filesystem::permissions(dir.path(), std::filesystem::perms::all);
    for (const auto& file : std::filesystem::directory_iterator(dir.path())) std::filesystem::permissions(file.path(), std::filesystem::perms::all);
    std::filesystem::permissions(dir.file("read-only"), std::filesystem::perms::owner_all | std::filesystem::perms::group_read |
                                                            std::filesystem::perms::group_exec | std::filesystem::perms::others_read |
                                                            std::filesystem::perms::others_exec);
    if (const char* cookie = std::getenv("XAUTHORITY")) {
      std::filesystem::copy_file(cookie, dir.file("xauthority"));
      std::filesystem::permissions(dir.file("xauthority"), std::filesystem::perms::all);
    }
    arguments.insert(arguments.end(), {"--screenshot-dir", dir.path().string()});
    editor.emplace(arguments, std::vector<std::string>{"setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "env",
                                                       "XAUTHORITY=" + dir.file("xauthority").string(), "HOME=" + dir.path().string()});
  } else {
    std::filesystem::permissions(dir.file("read-only"), std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec);
    arguments.insert(arguments.end(), {"--screenshot-dir", dir.path().string()});
    editor.emplace(arguments);
  }
  ASSERT_NO_FATAL_FAILURE(until_ready(*editor));
  press("g");
  drag_and_settle(*editor, Eigen::Vector2f::Zero(), Eigen::Vector2f(100.0f, 0.0f), 8);
  const auto before = editor->event_count();
  press("ctrl+s");
  const json error = editor->wait_for("error", 60s, before);
  EXPECT_NE(error.value("message", "").find("read-only/saved.obj"), std::string::npos) << error.dump();
  const json dialog = editor->wait_for("dialog", 30s, before);
  EXPECT_EQ(dialog.value("title", ""), "Could not save");
  EXPECT_TRUE(std::filesystem::is_empty(dir.file("read-only"))) << "a failed save writes nothing";
  const engine::Pixels shown = window_picture(*editor);
  EXPECT_GT(title_bar_pixels(shown), 1000) << "no dialog in the middle of the window";
  press("Escape");
  quit_discarding_changes(*editor);
}

// Saving when the set-up failed (a handle with no fixed vertex): there is no result to write, and
// the dialog says why; the editor goes on.
TEST_F(EditorGui, SavingAfterAFailedSetUpSaysWhyAndGoesOn) {
  dir.write("handle.txt", "0\n1\n2\n");
  auto arguments = editor_arguments("no");
  arguments.insert(arguments.end(), {"--handle", dir.file("handle.txt").string()});
  Editor editor(arguments);
  editor.wait_for("opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  const auto deadline = Clock::now() + 60s;
  const auto failed = [&] {
    for (const json& event : editor.events_named("solver")) {
      if (event.value("state", "") == "failed") return true;
    }
    return false;
  };
  while (!failed() && Clock::now() < deadline) std::this_thread::sleep_for(100ms);
  ASSERT_TRUE(failed()) << "the set-up should fail: the handle has no fixed vertex";
  const auto before = editor.event_count();
  press("ctrl+s");
  const json dialog = editor.wait_for("dialog", 30s, before);
  EXPECT_EQ(dialog.value("title", ""), "Could not save");
  EXPECT_NE(dialog.value("message", "").find("no fixed vertex"), std::string::npos) << dialog.dump();
  EXPECT_FALSE(std::filesystem::exists(dir.file("saved.obj")));
  press("Escape");
  quit(editor);  // nothing was edited
}

// A vertex list given with a mesh that cannot be used: the mesh opens anyway, without the lists,
// and the window says which file and line, and why.
TEST_F(EditorGui, ABadFixedListLeavesTheMeshOpenAndSaysWhy) {
  dir.write("bad.txt", "1\n2\nabc\n");
  std::vector<std::string> arguments = editor_arguments("no");
  arguments.insert(arguments.begin() + 1, {"--fixed", dir.file("bad.txt").string()});
  Editor editor(arguments);
  const json opened = editor.wait_for("opened");
  EXPECT_EQ(opened.value("mesh", ""), dir.file("cactus.obj").string());
  const json error = editor.wait_for("error");
  EXPECT_NE(error.value("message", "").find("bad.txt:3"), std::string::npos) << error.dump();
  EXPECT_EQ(editor.wait_for("dialog").value("title", ""), "Could not open");
  ASSERT_NO_FATAL_FAILURE(find_window());
  EXPECT_GT(title_bar_pixels(window_picture(editor)), 1000) << "no dialog in the middle of the window";
  press("Escape");
  quit(editor);
}

// The markers file a transfer session saves to survives restore after restore: each restore's
// recovery file still names it (a second crash used to forget it).
TEST_F(EditorGui, TransferModeKeepsItsMarkersFileAcrossTwoCrashes) {
  const std::vector<std::string> arguments{"--size", std::to_string(kWidth) + "x" + std::to_string(kHeight), "--recovery-file",
                                           dir.file("recovery.json").string(), "--validation", "--transfer-source", dir.file("cactus.obj").string(),
                                           "--transfer-target", dir.file("cactus.obj").string(), "--markers", dir.file("markers.txt").string()};
  const float view_width = (kWidth - kPanelWidth) / 2.0f;
  int round = 0;
  for (const char* restore : {"no", "yes", "yes"}) {
    const float height = kHeight * (0.45f + 0.1f * static_cast<float>(round++));  // another vertex each round
    SCOPED_TRACE(std::string("--restore ") + restore);
    std::vector<std::string> run = arguments;
    run.insert(run.end(), {"--restore", restore});
    Editor editor(run);
    ASSERT_FALSE(editor.wait_for(restore == std::string("no") ? "transfer opened" : "transfer restored").is_null());
    ASSERT_NO_FATAL_FAILURE(find_window());
    // A pair more each time, written to the recovery file before the kill.
    const auto before = editor.event_count();
    move_to({kPanelWidth + 0.5f * view_width, height});
    xdotool("click 1");
    std::this_thread::sleep_for(250ms);
    move_to({kPanelWidth + 1.5f * view_width, height});
    xdotool("click 1");
    editor.wait_for("marker added", 30s, before);
    editor.wait_for("transfer recovery", 30s, before);
    editor.kill_now();
    const cli::TransferState kept = cli::read_transfer_state(dir.file("recovery-transfer.json"));
    EXPECT_EQ(kept.markers_file, dir.file("markers.txt").string());
  }
}

// Quit in transfer mode with a marker pair just added asks, and its recovery file stays until the
// answer; Cancel keeps the pair.
TEST_F(EditorGui, QuitInTransferModeWithANewMarkerPairAsksFirst) {
  Editor editor({"--size", std::to_string(kWidth) + "x" + std::to_string(kHeight), "--recovery-file", dir.file("recovery.json").string(),
                 "--restore", "no", "--validation", "--transfer-source", dir.file("cactus.obj").string(), "--transfer-target",
                 dir.file("cactus.obj").string(), "--markers", dir.file("markers.txt").string()});
  editor.wait_for("transfer opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  const float view_width = (kWidth - kPanelWidth) / 2.0f;
  const auto before = editor.event_count();
  move_to({kPanelWidth + 0.5f * view_width, kHeight * 0.55f});
  xdotool("click 1");
  std::this_thread::sleep_for(250ms);
  move_to({kPanelWidth + 1.5f * view_width, kHeight * 0.55f});
  xdotool("click 1");
  editor.wait_for("marker added", 30s, before);
  editor.wait_for("transfer recovery", 30s, before);
  auto asked_at = editor.event_count();
  press("ctrl+q");
  const json asked = editor.wait_for("dialog", 30s, asked_at);
  EXPECT_EQ(asked.value("title", ""), "Unsaved changes");
  EXPECT_EQ(asked.value("markers", ""), "1 marker pair (never saved)");
  std::this_thread::sleep_for(300ms);
  EXPECT_TRUE(std::filesystem::exists(dir.file("recovery-transfer.json"))) << "the recovery file goes only once the user chose";
  press("Escape");
  EXPECT_EQ(editor.wait_for("dialog closed", 30s, asked_at).value("choice", ""), "cancel");
  // Save: the pairs go to their file, then the editor quits.
  asked_at = editor.event_count();
  press("ctrl+q");
  editor.wait_for("dialog", 30s, asked_at);
  press("Return");
  const json saved = editor.wait_for("markers saved", 30s, asked_at);
  EXPECT_EQ(saved.value("count", 0), 1);
  EXPECT_EQ(editor.wait_exit(), 0);
  std::ifstream written(dir.file("markers.txt"));
  int pairs = 0;
  for (std::string line; std::getline(written, line);) pairs += line.empty() || line[0] == '#' ? 0 : 1;
  EXPECT_EQ(pairs, 1) << "the saved file holds the new pair";
}

}  // namespace
}  // namespace hdeform

// The editor as a user drives it: `hdeform gui` under Xvfb (ctest runs this under xvfb-run),
// real X input from xdotool (pointer moves, button and key presses through XTEST), and the files
// it writes. Paint a sink and a handle, drag the handle, save: the saved mesh is the batch replay
// of the saved session and moved where the handle did; the window's screenshot is the offscreen
// render of the same state; kill -9 and restart restores the state before the kill; a bad mesh
// is explained in a dialog; typed values are undoable and reach the recovery file; SIGTERM keeps
// the session for a restore prompt that names it; the validation layer reports nothing.
#include <limits>
#include <set>

#include "editor_gui_harness.h"
#include "hdeform/engine/proxy_mesh.h"

namespace hdeform {
namespace {

using namespace gui_test;

TEST_F(EditorGui, PaintDragAndSaveGiveTheBatchReplayAndTheScreenShowsTheOffscreenPicture) {
  Editor editor(editor_arguments("no"));
  editor.wait_for("opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  const Eigen::Vector2f tip = paint_sink_and_handle(editor);
  const auto drag_events = editor.event_count();
  grab_and_drag(tip, {90.0f, -40.0f});
  // The picture below is of the saved (refined) result: taken once the screen shows it, not an
  // iteration on the way there.
  editor.wait_for("refined", 60s, drag_events);
  const json saved = save(editor);
  ASSERT_FALSE(saved.is_null());
  const json screenshot = take_screenshot(editor);
  quit(editor);

  // The session holds what was painted, where it was painted.
  const auto session = cli::read_session(saved["session"].get<std::string>());
  ASSERT_FALSE(session.current.fixed.empty());
  ASSERT_EQ(session.current.handles.size(), 1u);
  const auto& handle = session.current.handles[0];
  ASSERT_FALSE(handle.vertices.empty());
  const double diagonal = (rest.positions.colwise().maxCoeff() - rest.positions.colwise().minCoeff()).norm();
  // The brush (3% of the diagonal) swept a few pixels around the aimed vertex.
  const auto near = [&](int v, int aimed) { return (rest.positions.row(v) - rest.positions.row(aimed)).norm() < 0.1 * diagonal; };
  for (const int v : handle.vertices) EXPECT_TRUE(near(v, aimed_handle)) << "handle vertex " << v << " is far from where the brush went";
  for (const int v : session.current.fixed) EXPECT_TRUE(near(v, aimed_sink)) << "fixed vertex " << v << " is far from where the brush went";
  EXPECT_GT(handle.transform.shift.norm(), 0.02 * diagonal) << "the drag should have moved the handle";

  // The saved mesh is the batch replay of the saved session, moved where the handle moved and
  // still where the sink holds it.
  const Mesh result = read_obj(saved["obj"].get<std::string>());
  const Eigen::MatrixXd replayed = replay(dir, saved["session"].get<std::string>(), "replayed.obj");
  ASSERT_EQ(replayed.rows(), result.positions.rows());
  EXPECT_LE((replayed - result.positions).cwiseAbs().maxCoeff(), 1e-12 * diagonal);
  double handle_motion = 0.0;
  for (const int v : handle.vertices) handle_motion = std::max(handle_motion, (result.positions.row(v) - rest.positions.row(v)).norm());
  EXPECT_GT(handle_motion, 0.02 * diagonal);
  for (const int v : session.current.fixed) EXPECT_LE((result.positions.row(v) - rest.positions.row(v)).norm(), 1e-9 * diagonal);

  // The window's picture of that state equals the offscreen renderer's.
  const auto context = test::validated_context();
  const engine::Pixels offscreen = offscreen_picture(*context, result, session.current);
  const engine::Pixels window_picture = engine::read_png(screenshot["path"].get<std::string>());
  ASSERT_EQ(window_picture.width, offscreen.width);
  ASSERT_EQ(window_picture.height, offscreen.height);
  const auto difference = test::compare_images(window_picture, offscreen, 24);
  EXPECT_LE(difference.differing_fraction, 0.005) << "largest channel difference " << difference.largest;
  EXPECT_EQ(context->validation_message_count(), 0u);
}

// On a mesh large enough for a proxy (lavapipe), a drag publishes only the proxy's vertices, and
// the drag's end publishes the whole shape again (without refinement, whose iterations would
// publish it anyway): the timeline says which was published when, and the screen then shows the
// whole saved mesh, as the offscreen renderer draws it. Its still pictures are drawn in slices
// (--slice-triangles, as a scan's are), and the last one, so assembled, is that picture.
TEST_F(EditorGui, ADragPublishesTheProxysVerticesAndTheShapeIsWholeAfterIt) {
  shape = make_shape(ShapeKind::Cactus, 128);
  ASSERT_GT(shape.mesh.triangle_count(), 2 * engine::kProxyTriangles) << "too small for a proxy";
  write_obj(dir.file("large.obj"), shape.mesh);
  rest = read_obj(dir.file("large.obj"));
  view.camera = engine::Camera::three_quarter_front(engine::Bounds::of(rest.positions), engine::UpAxis::Z, static_cast<float>(kWidth) / kHeight,
                                                    kPanelWidth / static_cast<float>(kWidth));
  auto arguments = editor_arguments("no");
  arguments.front() = dir.file("large.obj").string();
  arguments.insert(arguments.end(), {"--no-refine", "--slice-triangles", "20000", "--trace", dir.file("trace.json").string()});
  Editor editor(arguments);
  editor.wait_for("opened");
  editor.wait_for("proxy");
  ASSERT_NO_FATAL_FAILURE(find_window());
  const Eigen::Vector2f tip = paint_sink_and_handle(editor);
  grab_and_drag(tip, {90.0f, -40.0f});
  const json saved = save(editor);
  ASSERT_FALSE(saved.is_null());
  const json screenshot = take_screenshot(editor);
  quit(editor);

  const auto events = test::read_checked_trace(dir.file("trace.json"));
  const auto partial = test::named(events, "positions and normals, the proxy's vertices");
  const auto whole = test::named(events, "positions and normals, every vertex");
  EXPECT_FALSE(partial.empty()) << "the drag published every vertex";
  ASSERT_FALSE(whole.empty());
  if (!partial.empty()) {
    const auto latest = [](const std::vector<test::TraceEvent>& list) {
      double at = 0.0;
      for (const auto& event : list) at = std::max(at, event.start_us);
      return at;
    };
    EXPECT_GT(latest(whole), latest(partial)) << "the drag's end was not published whole";
  }
  EXPECT_FALSE(test::named(events, "scene pass, a slice").empty()) << "no picture was drawn in slices";

  const Mesh result = read_obj(saved["obj"].get<std::string>());
  const auto session = cli::read_session(saved["session"].get<std::string>());
  ASSERT_EQ(session.current.handles.size(), 1u);
  const auto context = test::validated_context();
  const auto difference =
      test::compare_images(engine::read_png(screenshot["path"].get<std::string>()), offscreen_picture(*context, result, session.current), 24);
  EXPECT_LE(difference.differing_fraction, 0.005) << "largest channel difference " << difference.largest;
}

// --trace: the session's timeline holds the inputs, each frame's processor work, the device's
// time for it and its presentation, and the updates the drag asked for; no validation message.
TEST_F(EditorGui, ATraceHoldsInputsFramesTheDeviceAndTheUpdates) {
  auto arguments = editor_arguments("no");
  arguments.insert(arguments.end(), {"--trace", dir.file("trace.json").string()});
  Editor editor(arguments);
  editor.wait_for("opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  const Eigen::Vector2f tip = paint_sink_and_handle(editor);
  grab_and_drag(tip, Eigen::Vector2f(40, 30));
  save(editor);  // nothing unsaved: Ctrl+Q quits without asking
  quit(editor);
  const auto events = test::read_checked_trace(dir.file("trace.json"));
  for (const std::string name : {"pose input", "frame", "present", "update", "request", "solve", "factorization"}) {
    EXPECT_FALSE(test::named(events, name).empty()) << "no '" << name << "' in the trace";
  }
  EXPECT_FALSE(test::named(events, "device frame").empty()) << "no device time (lavapipe has timestamps)";
  EXPECT_GT(test::named(events, "frame").size(), 20u);
}

TEST_F(EditorGui, ThePointerOverThePanelRedrawsThePanelAndNotTheScene) {
  // On a CPU device a frame of a scan of millions of triangles takes seconds: the frames that only
  // the panel needs (the pointer over its buttons) show the scene kept from the last one drawn.
  Editor editor(editor_arguments("no"));
  editor.wait_for("opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  std::this_thread::sleep_for(1s);  // the first pictures are drawn
  for (int k = 0; k < 20; ++k) move_to({40.0f + 8.0f * static_cast<float>(k % 10), 150.0f + 15.0f * static_cast<float>(k)});
  const auto before = editor.event_count();
  press("ctrl+q");
  const json exit_event = editor.wait_for("exit", 60s, before);
  EXPECT_EQ(exit_event.value("validation_messages", -1), 0);
  EXPECT_EQ(editor.wait_exit(), 0);
  const int frames = exit_event.value("frames", 0), scene_frames = exit_event.value("scene_frames", 0);
  EXPECT_GE(scene_frames, 1);
  EXPECT_GE(frames - scene_frames, 15) << frames << " frames, " << scene_frames << " of them drew the scene";
}

// A stroke follows every position the pointer reported, not one per frame: on a CPU device a
// frame of a scan takes half a second, and a stroke painted dabs where the frames fell. Here the
// whole stroke comes in one burst (one xdotool call), so its moves share a frame or two.
TEST_F(EditorGui, AStrokeWhoseMovesArriveInOneFramePaintsItsWholePath) {
  Editor editor(editor_arguments("no"));
  editor.wait_for("opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  // The trunk's side that faces the camera, low and high (the arms leave it sideways).
  const auto trunk_front = [&](double height) {
    std::vector<int> ring;
    for (Eigen::Index v = 0; v < rest.vertex_count(); ++v) {
      const double r = rest.positions.row(v).head<2>().norm();
      if (std::abs(r - 0.1) < 1e-3 && std::abs(rest.positions(v, 2) - height) < 0.02) ring.push_back(static_cast<int>(v));
    }
    return facing_vertex(rest, ring, view);
  };
  const Eigen::Vector2f from = view.pixel(rest.positions.row(trunk_front(0.12)).transpose());
  const Eigen::Vector2f to = view.pixel(rest.positions.row(trunk_front(0.68)).transpose());
  ASSERT_GT((to - from).norm(), 100.0f) << "the trunk should cross much of the view";
  press("2");  // paint fixed
  move_to(from);
  std::string burst = "mousedown 1";
  constexpr int kSteps = 12;
  for (int k = 1; k <= kSteps; ++k) burst += " mousemove --window " + window + " " + at(from + (to - from) * (static_cast<float>(k) / kSteps));
  xdotool(burst + " mouseup 1");
  // What was painted, as saved: Ctrl+S is taken after the stroke's frames, whereas the recovery
  // file's timed write can fall in the middle of a slow stroke (under load, one held its first
  // dab alone).
  const auto before_save = editor.event_count();
  press("ctrl+s");
  const json saved = editor.wait_for("saved", 60s, before_save);
  const std::optional<cli::Session> session = cli::read_session(saved.value("session", std::string()));
  ASSERT_FALSE(session->current.fixed.empty());
  const std::set<int> fixed(session->current.fixed.begin(), session->current.fixed.end());
  // Every 5% of the way, the trunk's front vertex nearest to that pixel is painted.
  int missed = 0;
  for (int k = 0; k <= 20; ++k) {
    const Eigen::Vector2f pixel = from + (to - from) * (static_cast<float>(k) / 20.0f);
    int nearest = -1;
    float best = std::numeric_limits<float>::infinity();
    for (Eigen::Index v = 0; v < rest.vertex_count(); ++v) {
      const Eigen::Vector3d p = rest.positions.row(v).transpose();
      const Eigen::Vector2d outward = p.head<2>();
      const Eigen::Vector2d towards_camera = view.camera.position().head<2>().cast<double>() - outward;
      if (std::abs(outward.norm() - 0.1) > 1e-3 || outward.dot(towards_camera) <= 0.0) continue;  // not the trunk's side we see
      const float distance = (view.pixel(p) - pixel).norm();
      if (distance < best) {
        best = distance;
        nearest = static_cast<int>(v);
      }
    }
    ASSERT_GE(nearest, 0);
    if (fixed.count(nearest) == 0) ++missed;
  }
  EXPECT_EQ(missed, 0) << "of 21 points along the stroke; " << fixed.size() << " vertices painted";
  press("ctrl+q");  // saved: no question
  EXPECT_EQ(editor.wait_exit(), 0);
}

TEST_F(EditorGui, AfterKillNineTheNextStartRestoresTheStateBeforeTheKill) {
  cli::Session before_kill;
  {
    Editor editor(editor_arguments("no"));
    editor.wait_for("opened");
    ASSERT_NO_FATAL_FAILURE(find_window());
    const Eigen::Vector2f tip = paint_sink_and_handle(editor);
    grab_and_drag(tip, {-70.0f, -50.0f});
    // The finished drag is written to the recovery file at once (atomically: a reader never sees
    // half a file).
    const auto deadline = Clock::now() + 30s;
    bool written = false;
    while (!written && Clock::now() < deadline) {
      try {
        before_kill = cli::read_session(dir.file("recovery.json"));
        written = before_kill.current.handles.size() == 1 && before_kill.current.handles[0].transform.shift.norm() > 0.0 &&
                  !before_kill.current.fixed.empty();
      } catch (const std::exception&) {
      }
      if (!written) std::this_thread::sleep_for(100ms);
    }
    ASSERT_TRUE(written) << "the recovery file never held the drag";
    editor.kill_now();
  }
  ASSERT_TRUE(std::filesystem::exists(dir.file("recovery.json")));

  Editor editor(editor_arguments("ask"));
  editor.wait_for("restore prompt");
  ASSERT_NO_FATAL_FAILURE(find_window());
  press("Return");
  editor.wait_for("opened");
  EXPECT_EQ(editor.settled_solver_state(), "ready");
  const json saved = save(editor);
  ASSERT_FALSE(saved.is_null());
  quit(editor);
  EXPECT_FALSE(std::filesystem::exists(dir.file("recovery.json"))) << "a clean exit removes the recovery file";

  const auto restored = cli::read_session(saved["session"].get<std::string>());
  EXPECT_EQ(restored.current, before_kill.current);
  const Mesh result = read_obj(saved["obj"].get<std::string>());
  const Eigen::MatrixXd replayed = replay(dir, saved["session"].get<std::string>(), "replayed.obj");
  ASSERT_EQ(replayed.rows(), result.positions.rows());
  EXPECT_EQ(replayed, result.positions);
  double moved = 0.0;
  for (const int v : restored.current.handles[0].vertices) moved = std::max(moved, (result.positions.row(v) - rest.positions.row(v)).norm());
  EXPECT_GT(moved, 0.0) << "the restored mesh shows the drag";
}

// A user's session, scripted with random choices, killed with SIGKILL at random moments over and
// over, each start restoring the last: the recovery file always parses, always holds a state the
// editor announced (a state the user had), never one older than what was announced a few seconds
// before the kill, and the next start shows exactly that state.
TEST_F(EditorGui, RecoveryFileSurvivesKillNineAtRandomMoments) {
  unsigned seed = 20261123;
  if (const char* given = std::getenv("HDEFORM_KILL_SEED")) seed = static_cast<unsigned>(std::stoul(given));
  std::mt19937 random(seed);
  constexpr int kRounds = 6;
  constexpr auto kAtMostLost = 3s;  // the editor writes within milliseconds; this allows a loaded machine
  const auto recovery_file = dir.file("recovery.json");
  const auto sink = view.pixel(rest.positions.row(facing_vertex(rest, shape.demo_constraints.fixed, view)).transpose());
  const auto tip = view.pixel(rest.positions.row(facing_vertex(rest, shape.demo_constraints.handles[0], view)).transpose());

  struct Announcement {
    std::string digest;
    Clock::time_point received;
  };
  std::vector<Announcement> announced;  // every state put in the recovery file, all runs
  std::string expected_on_restore;      // the digest of the recovery file the next start finds
  for (int round = 0; round < kRounds; ++round) {
    const auto kill_after = std::chrono::milliseconds(std::uniform_int_distribution<int>(300, 7000)(random));
    const unsigned script_seed = static_cast<unsigned>(random());
    Editor editor(editor_arguments(round == 0 ? "no" : "yes"));
    const auto started = Clock::now();
    std::atomic<bool> stop = false;
    // The user: paints a sink and a handle, then drags, undoes and paints more, at random. Any
    // step may fail once the editor is gone; the script just ends.
    std::thread user([&] {
      std::mt19937 choices(script_seed);
      const auto act = [&](const std::string& arguments, std::chrono::milliseconds pause) {
        if (stop) return false;
        const bool done = shell("xdotool " + arguments + " 2>/dev/null").first == 0;
        std::this_thread::sleep_for(pause);
        return done && !stop;
      };
      std::string editor_window;
      while (!stop && editor_window.empty()) {
        const auto [status, out] = shell("xdotool search --onlyvisible --name '^hdeform' 2>/dev/null");
        if (status == 0 && !out.empty()) editor_window = out.substr(0, out.find('\n'));
        else std::this_thread::sleep_for(100ms);
      }
      if (!act("windowfocus " + editor_window, 50ms)) return;
      const auto move = [&](const Eigen::Vector2f& p) { return act("mousemove --window " + editor_window + " " + at(p), 40ms); };
      const auto key = [&](const std::string& name) { return act("keydown " + name, 60ms) && act("keyup " + name, 150ms); };
      const auto stroke = [&](const Eigen::Vector2f& from, const Eigen::Vector2f& to) {
        if (!move(from) || !act("mousedown 1", 100ms)) return false;
        for (int k = 1; k <= 6; ++k) {
          if (!move(from + (to - from) * (static_cast<float>(k) / 6.0f))) return false;
        }
        return act("mouseup 1", 250ms);
      };
      if (!key("2") || !stroke(sink + Eigen::Vector2f(-6, 0), sink + Eigen::Vector2f(6, 0))) return;
      if (!key("3") || !stroke(tip + Eigen::Vector2f(0, -4), tip + Eigen::Vector2f(0, 4))) return;
      std::uniform_real_distribution<float> offset(-60.0f, 60.0f);
      for (;;) {
        const int choice = std::uniform_int_distribution<int>(0, 9)(choices);
        if (choice < 6) {
          if (!key("g") || !stroke(tip, tip + Eigen::Vector2f(offset(choices), offset(choices)))) return;
        } else if (choice < 8) {
          if (!key("ctrl+z")) return;
        } else {
          if (!key("3") || !stroke(tip + Eigen::Vector2f(offset(choices) * 0.1f, -4), tip + Eigen::Vector2f(0, 4))) return;
        }
      }
    });
    std::this_thread::sleep_until(started + kill_after);
    editor.kill_now();
    const auto killed = Clock::now();
    stop = true;
    user.join();
    // What the script held when the editor died stays held in the X server otherwise, for the rest
    // of the run (-noreset): a '2' left down swallowed the first '2' a later test typed.
    shell("xdotool keyup 2 3 g ctrl+z mouseup 1 2>/dev/null");

    const auto events = editor.all_events();
    for (const auto& [event, received] : events) {
      if (event.value("event", "") == "recovery") announced.push_back({event.value("digest", ""), received});
      if (event.value("event", "") == "opened" && !expected_on_restore.empty()) {
        EXPECT_EQ(event.value("session_digest", ""), expected_on_restore) << "round " << round << ": the start did not restore the recovery file";
      }
      EXPECT_NE(event.value("event", ""), "error") << "round " << round << ": " << event.dump();
    }
    std::cerr << "round " << round << " (seed " << seed << "): killed after " << kill_after.count() << " ms, " << announced.size()
              << " states announced so far\n";
    if (!std::filesystem::exists(recovery_file)) {
      // A state is announced just before its write, so a kill right after the first announcement
      // (a slow start under a sanitizer) can leave no file yet; one announced earlier cannot.
      for (const auto& state : announced) {
        EXPECT_GT(state.received, killed - kAtMostLost) << "round " << round << ": the recovery file is gone although a state was announced "
                                                        << std::chrono::duration_cast<std::chrono::milliseconds>(killed - state.received).count()
                                                        << " ms before the kill";
      }
      continue;
    }
    cli::Session recovered;
    ASSERT_NO_THROW(recovered = cli::read_session(recovery_file)) << "round " << round << ": the recovery file is damaged";
    expected_on_restore = cli::session_digest(recovered);
    std::size_t latest = announced.size();
    for (std::size_t k = 0; k < announced.size(); ++k) {
      if (announced[k].digest == expected_on_restore) latest = k;
    }
    ASSERT_LT(latest, announced.size()) << "round " << round << ": the recovery file holds a state the editor never had";
    for (std::size_t k = latest + 1; k < announced.size(); ++k) {
      EXPECT_GT(announced[k].received, killed - kAtMostLost) << "round " << round << ": a state announced " << k - latest
                                                             << " states later, more than a few seconds before the kill, was lost";
    }
  }

  // A clean start restores the last state, exits cleanly, and leaves nothing behind. Restored
  // work is in no file yet: Quit asks before it discards it.
  Editor editor(editor_arguments("yes"));
  const json opened = editor.wait_for("opened");
  if (!expected_on_restore.empty()) {
    EXPECT_EQ(opened.value("session_digest", ""), expected_on_restore);
  }
  ASSERT_NO_FATAL_FAILURE(find_window());
  if (expected_on_restore.empty()) quit(editor);
  else quit_discarding_changes(editor);
  std::vector<std::string> left;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    if (entry.path().filename().string().starts_with(".recovery.json")) left.push_back(entry.path().filename().string());
  }
  EXPECT_TRUE(left.empty()) << "temporary recovery files remain, e.g. " << (left.empty() ? "" : left.front());
  EXPECT_FALSE(std::filesystem::exists(recovery_file)) << "a clean exit removes the recovery file";
}
}  // namespace
}  // namespace hdeform

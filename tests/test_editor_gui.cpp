// The editor as a user drives it: `hdeform gui` under Xvfb (ctest runs this under xvfb-run),
// real X input from xdotool (pointer moves, button and key presses through XTEST), and the files
// it writes. Paint a sink and a handle, drag the handle, save: the saved mesh is the batch replay
// of the saved session and moved where the handle did; the window's screenshot is the offscreen
// render of the same state; kill -9 and restart restores the state before the kill; a bad mesh
// is explained in a dialog; typed values are undoable and reach the recovery file; SIGTERM keeps
// the session for a restore prompt that names it; the validation layer reports nothing.
#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <functional>
#include <mutex>
#include <numbers>
#include <optional>
#include <random>
#include <thread>

#include "hdeform/deformer.h"
#include "hdeform/engine/image_io.h"
#include "hdeform/engine/offscreen.h"
#include "hdeform/errors.h"
#include "hdeform/marker_io.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "render_support.h"
#include "session.h"
#include "transfer_state.h"
#include "test_support.h"
#include "trace_checks.h"

extern char** environ;

namespace hdeform {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

constexpr int kWidth = 1200;
constexpr int kHeight = 700;
constexpr float kPanelWidth = 330.0f;  // the editor's side panel covers the view left of this

// Runs a shell command; returns its exit status and standard output.
std::pair<int, std::string> shell(const std::string& command) {
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  char buffer[4096];
  while (const auto n = std::fread(buffer, 1, sizeof buffer, pipe)) out.append(buffer, n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

void xdotool(const std::string& arguments) {
  const auto [status, out] = shell("xdotool " + arguments + " 2>&1");
  ASSERT_EQ(status, 0) << "xdotool " << arguments << ": " << out;
}

// The editor as a child process; its stdout's JSON lines are collected as they come.
class Editor {
 public:
  explicit Editor(const std::vector<std::string>& arguments) {
    int out[2];
    if (pipe(out) != 0) throw std::runtime_error("pipe failed");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, out[0]);
    std::vector<std::string> argv_storage{HDEFORM_EXECUTABLE, "gui"};
    argv_storage.insert(argv_storage.end(), arguments.begin(), arguments.end());
    std::vector<char*> argv;
    for (auto& argument : argv_storage) argv.push_back(argument.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, HDEFORM_EXECUTABLE, &actions, nullptr, argv.data(), environ) != 0) throw std::runtime_error("spawn failed");
    posix_spawn_file_actions_destroy(&actions);
    close(out[1]);
    reader_ = std::thread([this, fd = out[0]] {
      std::string pending;
      char buffer[4096];
      ssize_t n = 0;
      while ((n = read(fd, buffer, sizeof buffer)) > 0) {
        pending.append(buffer, static_cast<std::size_t>(n));
        for (auto end = pending.find('\n'); end != std::string::npos; end = pending.find('\n')) {
          const std::string line = pending.substr(0, end);
          pending.erase(0, end + 1);
          std::fprintf(stderr, "editor: %s\n", line.c_str());
          std::lock_guard lock(mutex_);
          try {
            events_.push_back(json::parse(line));
          } catch (const json::exception&) {
            events_.push_back(json{{"event", "text"}, {"text", line}});
          }
          arrival_.push_back(Clock::now());
          arrived_.notify_all();
        }
      }
      close(fd);
      std::lock_guard lock(mutex_);
      output_closed_ = true;
      arrived_.notify_all();
    });
  }
  ~Editor() {
    if (pid_ > 0) kill_now();
    if (reader_.joinable()) reader_.join();
  }

  // The first event named `name` after the first `after` events (any, when `after` is 0).
  json wait_for(const std::string& name, std::chrono::seconds timeout = 120s, std::size_t after = 0) {
    std::unique_lock lock(mutex_);
    json found;
    bool arrived = false;
    arrived_.wait_for(lock, timeout, [&] {
      for (std::size_t k = after; k < events_.size(); ++k) {
        if (events_[k].value("event", "") == name) {
          found = events_[k];
          arrived = true;
          return true;
        }
      }
      return output_closed_;
    });
    if (!arrived && output_closed_) {
      ADD_FAILURE() << "the editor closed its output (ended?) before reporting '" << name << "'";
    } else if (!arrived) {
      ADD_FAILURE() << "the editor did not report '" << name << "' within " << timeout.count() << " s";
    }
    return found;
  }
  std::size_t event_count() {
    std::lock_guard lock(mutex_);
    return events_.size();
  }
  // The newest solver state reported, once none has arrived for `quiet` (the deformer is rebuilt
  // while a selection changes; the last rebuild decides).
  std::string settled_solver_state(std::chrono::milliseconds quiet = 1500ms, std::chrono::seconds timeout = 120s) {
    const auto deadline = Clock::now() + timeout;
    std::string state;
    std::size_t seen = 0;
    auto last_change = Clock::now();
    while (Clock::now() < deadline) {
      {
        std::lock_guard lock(mutex_);
        for (; seen < events_.size(); ++seen) {
          if (events_[seen].value("event", "") != "solver") continue;
          state = events_[seen].value("state", "");
          last_change = Clock::now();
        }
        if (output_closed_) break;
      }
      if (state == "ready" && Clock::now() - last_change > quiet) return state;
      std::this_thread::sleep_for(50ms);
    }
    return state;
  }

  int wait_exit(std::chrono::seconds timeout = 60s) {
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(50ms);
    }
    ADD_FAILURE() << "the editor did not exit within " << timeout.count() << " s";
    kill_now();
    return -1;
  }
  void send(int signal) { ::kill(pid_, signal); }
  void kill_now() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  // After the process has ended: every event it printed, with when the test received it (never
  // earlier than when it was printed).
  std::vector<std::pair<json, Clock::time_point>> all_events() {
    if (reader_.joinable()) reader_.join();
    std::vector<std::pair<json, Clock::time_point>> all;
    for (std::size_t k = 0; k < events_.size(); ++k) all.emplace_back(events_[k], arrival_[k]);
    return all;
  }

 private:
  pid_t pid_ = -1;
  std::thread reader_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  bool output_closed_ = false;  // the editor's stdout reached its end: no more events will come
  std::vector<json> events_;
  std::vector<Clock::time_point> arrival_;
};

// Where the editor's default view puts a point of the rest shape, in window pixels.
struct View {
  engine::Camera camera;
  Eigen::Vector2f pixel(const Eigen::Vector3d& point) const {
    const Eigen::Vector4f clip = camera.view_projection(static_cast<float>(kWidth) / kHeight) * Eigen::Vector4f(point.cast<float>().homogeneous());
    return {(clip.x() / clip.w() * 0.5f + 0.5f) * kWidth, (clip.y() / clip.w() * 0.5f + 0.5f) * kHeight};
  }
  float depth(const Eigen::Vector3d& point) const { return (point.cast<float>() - camera.position()).norm(); }
};

// The vertex of `vertices` nearest the camera: on the side the user sees.
int facing_vertex(const Mesh& mesh, const std::vector<int>& vertices, const View& view) {
  return *std::min_element(vertices.begin(), vertices.end(), [&](int a, int b) {
    return view.depth(mesh.positions.row(a).transpose()) < view.depth(mesh.positions.row(b).transpose());
  });
}

std::string at(const Eigen::Vector2f& p) { return std::to_string(static_cast<int>(std::lround(p.x()))) + " " + std::to_string(static_cast<int>(std::lround(p.y()))); }

class EditorGui : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no X display (ctest runs this under xvfb-run)";
    if (shell("command -v xdotool").first != 0) GTEST_SKIP() << "xdotool is not installed (scripts/setup installs it)";
    shape = make_shape(ShapeKind::Cactus, 24);
    write_obj(dir.file("cactus.obj"), shape.mesh);
    rest = read_obj(dir.file("cactus.obj"));  // as the editor reads it
    view.camera = engine::Camera::three_quarter_front(engine::Bounds::of(rest.positions), engine::UpAxis::Z, static_cast<float>(kWidth) / kHeight);
  }

  std::vector<std::string> editor_arguments(const std::string& restore) const {
    return {dir.file("cactus.obj").string(), "--size", std::to_string(kWidth) + "x" + std::to_string(kHeight),
            "--recovery-file", dir.file("recovery.json").string(), "--restore", restore,
            "--output", dir.file("saved.obj").string(), "--screenshot-dir", dir.path().string(), "--validation"};
  }

  // A built-in shape with its demo's sink and handle painted, the recovery file in the test's folder.
  std::vector<std::string> shape_arguments(const std::string& shape_name, const char* restore) const {
    return {shape_name, "--size", std::to_string(kWidth) + "x" + std::to_string(kHeight), "--recovery-file", dir.file("recovery.json").string(),
            "--restore", restore, "--validation"};
  }

  // The editor's window: found by title, given the keyboard focus, the pointer over its view.
  void find_window() {
    const auto deadline = Clock::now() + 60s;
    while (Clock::now() < deadline) {
      const auto [status, out] = shell("xdotool search --onlyvisible --name '^hdeform' 2>/dev/null");
      if (status == 0 && !out.empty()) {
        window = out.substr(0, out.find('\n'));
        xdotool("windowfocus " + window);
        move_to({kWidth * 0.75f, kHeight * 0.5f});
        return;
      }
      std::this_thread::sleep_for(100ms);
    }
    FAIL() << "no editor window appeared";
  }

  void move_to(const Eigen::Vector2f& p) {
    xdotool("mousemove --window " + window + " " + at(p));
    std::this_thread::sleep_for(60ms);
  }
  // A key held as long as a person holds it.
  void press(const std::string& key) {
    xdotool("keydown " + key);
    std::this_thread::sleep_for(80ms);
    xdotool("keyup " + key);
    std::this_thread::sleep_for(150ms);
  }
  // A press at `from`, a move to `to` in `steps`, a release.
  void drag(const Eigen::Vector2f& from, const Eigen::Vector2f& to, int steps) {
    move_to(from);
    xdotool("mousedown 1");
    std::this_thread::sleep_for(150ms);
    for (int k = 1; k <= steps; ++k) move_to(from + (to - from) * (static_cast<float>(k) / static_cast<float>(steps)));
    std::this_thread::sleep_for(150ms);
    xdotool("mouseup 1");
    std::this_thread::sleep_for(300ms);
  }

  // Paints the demo's sink (low on the trunk) and handle (tip of the left arm) with the brush,
  // aiming at their vertices that face the camera; returns the handle's pixel.
  Eigen::Vector2f paint_sink_and_handle(Editor& editor) {
    aimed_sink = facing_vertex(rest, shape.demo_constraints.fixed, view);
    aimed_handle = facing_vertex(rest, shape.demo_constraints.handles[0], view);
    const auto sink = view.pixel(rest.positions.row(aimed_sink).transpose());
    const auto tip = view.pixel(rest.positions.row(aimed_handle).transpose());
    EXPECT_GT(sink.x(), kPanelWidth + 10.0f) << "the sink is under the panel";
    EXPECT_GT(tip.x(), kPanelWidth + 10.0f) << "the handle is under the panel";
    press("2");  // paint fixed
    drag(sink + Eigen::Vector2f(-6, 0), sink + Eigen::Vector2f(6, 0), 4);
    press("3");  // paint handle
    drag(tip + Eigen::Vector2f(0, -4), tip + Eigen::Vector2f(0, 4), 4);
    EXPECT_EQ(editor.settled_solver_state(), "ready") << "painting a sink and a handle should give a solvable system";
    return tip;
  }

  // Moves the handle with the grab tool (the move follows the pointer wherever the drag starts).
  void grab_and_drag(const Eigen::Vector2f& from, const Eigen::Vector2f& by) {
    press("g");
    drag(from, from + by, 12);
    std::this_thread::sleep_for(700ms);  // the last solve lands
  }

  json save(Editor& editor) {
    const auto before = editor.event_count();
    press("ctrl+s");
    return editor.wait_for("saved", 60s, before);
  }

  // Ctrl+Q with unsaved changes asks first; Enter confirms.
  void quit_discarding_changes(Editor& editor) {
    const auto before = editor.event_count();
    press("ctrl+q");
    std::this_thread::sleep_for(300ms);
    press("Return");
    const json exit_event = editor.wait_for("exit", 60s, before);
    EXPECT_EQ(exit_event.value("validation_messages", -1), 0) << "Vulkan validation reported problems (see stderr)";
    EXPECT_EQ(editor.wait_exit(), 0);
  }

  void quit(Editor& editor) {
    const auto before = editor.event_count();
    press("ctrl+q");
    const json exit_event = editor.wait_for("exit", 60s, before);
    EXPECT_EQ(exit_event.value("validation_messages", -1), 0) << "Vulkan validation reported problems (see stderr)";
    EXPECT_EQ(editor.wait_exit(), 0);
  }

  test::TempDir dir;
  Shape shape;
  Mesh rest;
  View view;
  std::string window;
  int aimed_sink = -1;
  int aimed_handle = -1;
};

Eigen::MatrixXd replay(const test::TempDir& dir, const std::string& session, const std::string& out) {
  const auto [status, output] = shell(std::string(HDEFORM_EXECUTABLE) + " edit --session " + session + " --out " + dir.file(out).string() + " --quiet 2>&1");
  EXPECT_EQ(status, 0) << output;
  return read_obj(dir.file(out)).positions;
}

TEST_F(EditorGui, PaintDragAndSaveGiveTheBatchReplayAndTheScreenShowsTheOffscreenPicture) {
  Editor editor(editor_arguments("no"));
  editor.wait_for("opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  const Eigen::Vector2f tip = paint_sink_and_handle(editor);
  grab_and_drag(tip, {90.0f, -40.0f});
  const json saved = save(editor);
  ASSERT_FALSE(saved.is_null());
  const auto screenshot_events = editor.event_count();
  press("F12");
  const json screenshot = editor.wait_for("screenshot", 60s, screenshot_events);
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
  engine::Scene scene;
  scene.positions = result.positions;
  scene.triangles = rest.triangles;
  scene.rest_bounds = engine::Bounds::of(rest.positions);
  const Deformer deformer(rest, session.current.constraints());
  scene.field = deformer.field();
  scene.classes.assign(static_cast<std::size_t>(rest.vertex_count()), HD_CLASS_FREE);
  for (const int v : session.current.fixed) scene.classes[static_cast<std::size_t>(v)] = engine::fixed_class();
  for (const int v : handle.vertices) scene.classes[static_cast<std::size_t>(v)] = engine::handle_class(0);
  engine::Shot shot;
  shot.width = kWidth;
  shot.height = kHeight;
  shot.samples = 1;  // the editor's on a CPU device
  const auto context = test::validated_context();
  const engine::Pixels offscreen = engine::render_offscreen(*context, scene, shot);
  const engine::Pixels window_picture = engine::read_png(screenshot["path"].get<std::string>());
  ASSERT_EQ(window_picture.width, offscreen.width);
  ASSERT_EQ(window_picture.height, offscreen.height);
  const auto difference = test::compare_images(window_picture, offscreen, 24);
  EXPECT_LE(difference.differing_fraction, 0.005) << "largest channel difference " << difference.largest;
  EXPECT_EQ(context->validation_message_count(), 0u);
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
    shell("xdotool mouseup 1 2>/dev/null");  // a button held when the editor died stays held otherwise

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
      EXPECT_TRUE(announced.empty()) << "round " << round << ": the recovery file is gone although states were announced";
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

  // A clean start restores the last state, exits cleanly, and leaves nothing behind.
  Editor editor(editor_arguments("yes"));
  const json opened = editor.wait_for("opened");
  if (!expected_on_restore.empty()) {
    EXPECT_EQ(opened.value("session_digest", ""), expected_on_restore);
  }
  ASSERT_NO_FATAL_FAILURE(find_window());
  quit(editor);
  std::vector<std::string> left;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    if (entry.path().filename().string().starts_with(".recovery.json")) left.push_back(entry.path().filename().string());
  }
  EXPECT_TRUE(left.empty()) << "temporary recovery files remain, e.g. " << (left.empty() ? "" : left.front());
  EXPECT_FALSE(std::filesystem::exists(recovery_file)) << "a clean exit removes the recovery file";
}

// Where the editor said its pose fields are: Move's x component, and the Angle field.
struct PoseFieldPixels {
  Eigen::Vector2f move_x, angle;
};
PoseFieldPixels pose_field_pixels(Editor& editor) {
  const json fields = editor.wait_for("pose fields");
  const float x = fields.value("x", 0.0f), y = fields.value("y", 0.0f), width = fields.value("width", 0.0f), row = fields.value("row", 0.0f);
  return {{x + 0.15f * width, y + 0.4f * row}, {x + 0.5f * width, y + 2.4f * row}};
}

// Polls the recovery file until `holds` accepts its session (a write is atomic: never half a file).
std::optional<cli::Session> recovery_holding(const std::filesystem::path& path, const std::function<bool(const cli::Session&)>& holds,
                                             std::chrono::seconds timeout = 20s) {
  const auto deadline = Clock::now() + timeout;
  std::optional<cli::Session> last;
  while (Clock::now() < deadline) {
    try {
      last = cli::read_session(path);
      if (holds(*last)) return last;
    } catch (const std::exception&) {
    }
    std::this_thread::sleep_for(100ms);
  }
  ADD_FAILURE() << "the recovery file never held the expected state" << (last ? "" : " (never readable)");
  return std::nullopt;
}

// The window as it looks (Shift+F12 writes it, panel and dialogs included).
engine::Pixels window_picture(Editor& editor) {
  const auto before = editor.event_count();
  xdotool("key shift+F12");
  const json shot = editor.wait_for("screenshot", 30s, before);
  return engine::read_png(shot.value("path", std::string()));
}

// How many pixels in the middle of the window have ImGui's active title-bar colour: a dialog.
int title_bar_pixels(const engine::Pixels& picture) {
  int count = 0;
  for (uint32_t y = picture.height / 4; y < picture.height * 3 / 4; ++y) {
    for (uint32_t x = picture.width / 4; x < picture.width * 3 / 4; ++x) {
      const uint8_t* p = &picture.rgba[(static_cast<std::size_t>(y) * picture.width + x) * 4];
      if (std::abs(p[0] - 41) <= 3 && std::abs(p[1] - 74) <= 3 && std::abs(p[2] - 122) <= 3) ++count;
    }
  }
  return count;
}

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
  editor.wait_for("opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  EXPECT_EQ(editor.settled_solver_state(), "ready");
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
                                        "--restore", "ask", "--validation"};
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
  editor.wait_for("opened");
  ASSERT_NO_FATAL_FAILURE(find_window());
  EXPECT_EQ(editor.settled_solver_state(), "ready");
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
  quit(editor);
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

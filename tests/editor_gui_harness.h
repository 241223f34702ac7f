#pragma once
// The editor driven as a user drives it, for test_editor_gui's files: the editor as a child
// process with its JSON events, xdotool, the default view's projection, the fixture and the
// helpers that read the recovery file and the window's pixels.
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
#include "model/session.h"
#include "model/transfer_state.h"
#include "test_support.h"
#include "trace_checks.h"

extern char** environ;

namespace hdeform::gui_test {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

inline constexpr int kWidth = 1200;
inline constexpr int kHeight = 700;
inline constexpr float kPanelWidth = 330.0f;  // the editor's side panel covers the view left of this

// Runs a shell command; returns its exit status and standard output.
inline std::pair<int, std::string> shell(const std::string& command) {
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  char buffer[4096];
  while (const auto n = std::fread(buffer, 1, sizeof buffer, pipe)) out.append(buffer, n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

inline void xdotool(const std::string& arguments) {
  const auto [status, out] = shell("xdotool " + arguments + " 2>&1");
  ASSERT_EQ(status, 0) << "xdotool " << arguments << ": " << out;
}

// The editor as a child process; its stdout's JSON lines are collected as they come. `prefix`
// runs it through another program (setpriv, to run it as another user).
class Editor {
 public:
  explicit Editor(const std::vector<std::string>& arguments, const std::vector<std::string>& prefix = {}) {
    int out[2];
    if (pipe(out) != 0) throw std::runtime_error("pipe failed");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, out[0]);
    std::vector<std::string> argv_storage = prefix;
    argv_storage.insert(argv_storage.end(), {HDEFORM_EXECUTABLE, "gui"});
    argv_storage.insert(argv_storage.end(), arguments.begin(), arguments.end());
    std::vector<char*> argv;
    for (auto& argument : argv_storage) argv.push_back(argument.data());
    argv.push_back(nullptr);
    if (posix_spawnp(&pid_, argv_storage.front().c_str(), &actions, nullptr, argv.data(), environ) != 0) throw std::runtime_error("spawn failed");
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
  // Every event named `name` so far, after the first `after`.
  std::vector<json> events_named(const std::string& name, std::size_t after = 0) {
    std::lock_guard lock(mutex_);
    std::vector<json> found;
    for (std::size_t k = after; k < events_.size(); ++k) {
      if (events_[k].value("event", "") == name) found.push_back(events_[k]);
    }
    return found;
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
inline int facing_vertex(const Mesh& mesh, const std::vector<int>& vertices, const View& view) {
  return *std::min_element(vertices.begin(), vertices.end(), [&](int a, int b) {
    return view.depth(mesh.positions.row(a).transpose()) < view.depth(mesh.positions.row(b).transpose());
  });
}

inline std::string at(const Eigen::Vector2f& p) { return std::to_string(static_cast<int>(std::lround(p.x()))) + " " + std::to_string(static_cast<int>(std::lround(p.y()))); }

class EditorGui : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no X display (ctest runs this under xvfb-run)";
    if (shell("command -v xdotool").first != 0) GTEST_SKIP() << "xdotool is not installed (scripts/setup installs it)";
    shape = make_shape(ShapeKind::Cactus, 24);
    write_obj(dir.file("cactus.obj"), shape.mesh);
    rest = read_obj(dir.file("cactus.obj"));  // as the editor reads it
    // The editor frames the mesh in the window right of its panel.
    view.camera = engine::Camera::three_quarter_front(engine::Bounds::of(rest.positions), engine::UpAxis::Z, static_cast<float>(kWidth) / kHeight,
                                                      kPanelWidth / static_cast<float>(kWidth));
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

  // Until the editor has opened its mesh, shown its window and finished the set-up.
  void until_ready(Editor& editor) {
    editor.wait_for("opened");
    ASSERT_NO_FATAL_FAILURE(find_window());
    EXPECT_EQ(editor.settled_solver_state(), "ready");
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

  // The offscreen renderer's picture of a saved result with its stage's field and painted classes,
  // framed as the editor frames it right of its panel: what the window shows once settled.
  engine::Pixels offscreen_picture(const engine::VulkanContext& context, const Mesh& result, const cli::EditStage& stage) const {
    engine::Scene scene;
    scene.positions = result.positions;
    scene.triangles = rest.triangles;
    scene.rest_bounds = engine::Bounds::of(rest.positions);
    const Deformer deformer(rest, stage.constraints());
    scene.field = deformer.field();
    scene.classes.assign(static_cast<std::size_t>(rest.vertex_count()), HD_CLASS_FREE);
    for (const int v : stage.fixed) scene.classes[static_cast<std::size_t>(v)] = engine::fixed_class();
    for (std::size_t h = 0; h < stage.handles.size(); ++h) {
      for (const int v : stage.handles[h].vertices) scene.classes[static_cast<std::size_t>(v)] = engine::handle_class(h);
    }
    engine::Shot shot;
    shot.width = kWidth;
    shot.height = kHeight;
    shot.samples = 1;  // the editor's on a CPU device
    shot.camera = view.camera;
    return engine::render_offscreen(context, scene, shot);
  }

  // F12: the window's picture, where the editor says it wrote it.
  json take_screenshot(Editor& editor) {
    const auto before = editor.event_count();
    press("F12");
    return editor.wait_for("screenshot", 60s, before);
  }

  json save(Editor& editor) {
    const auto before = editor.event_count();
    press("ctrl+s");
    return editor.wait_for("saved", 60s, before);
  }

  // Ctrl+Q with unsaved changes asks first; D discards them.
  void quit_discarding_changes(Editor& editor) {
    const auto before = editor.event_count();
    press("ctrl+q");
    const json asked = editor.wait_for("dialog", 30s, before);
    EXPECT_EQ(asked.value("title", ""), "Unsaved changes");
    press("d");
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

inline Eigen::MatrixXd replay(const test::TempDir& dir, const std::string& session, const std::string& out) {
  const auto [status, output] = shell(std::string(HDEFORM_EXECUTABLE) + " edit --session " + session + " --out " + dir.file(out).string() + " --quiet 2>&1");
  EXPECT_EQ(status, 0) << output;
  return read_obj(dir.file(out)).positions;
}


// Where the editor said its pose fields are: Move's x component, and the Angle field.
struct PoseFieldPixels {
  Eigen::Vector2f move_x, angle;
};
inline PoseFieldPixels pose_field_pixels(Editor& editor) {
  const json fields = editor.wait_for("pose fields");
  const float x = fields.value("x", 0.0f), y = fields.value("y", 0.0f), width = fields.value("width", 0.0f), row = fields.value("row", 0.0f);
  return {{x + 0.15f * width, y + 0.4f * row}, {x + 0.5f * width, y + 2.4f * row}};
}

// Polls the recovery file until `holds` accepts its session (a write is atomic: never half a file).
inline std::optional<cli::Session> recovery_holding(const std::filesystem::path& path, const std::function<bool(const cli::Session&)>& holds,
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
inline engine::Pixels window_picture(Editor& editor) {
  const auto before = editor.event_count();
  xdotool("key shift+F12");
  const json shot = editor.wait_for("screenshot", 30s, before);
  return engine::read_png(shot.value("path", std::string()));
}

// How many pixels in the middle of the window have ImGui's active title-bar colour: a dialog.
inline int title_bar_pixels(const engine::Pixels& picture) {
  int count = 0;
  for (uint32_t y = picture.height / 4; y < picture.height * 3 / 4; ++y) {
    for (uint32_t x = picture.width / 4; x < picture.width * 3 / 4; ++x) {
      const uint8_t* p = &picture.rgba[(static_cast<std::size_t>(y) * picture.width + x) * 4];
      if (std::abs(p[0] - 41) <= 3 && std::abs(p[1] - 74) <= 3 && std::abs(p[2] - 122) <= 3) ++count;
    }
  }
  return count;
}
}  // namespace hdeform::gui_test

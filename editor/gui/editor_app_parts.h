#pragma once
// The editor window, EditorApp, whose parts are defined in editor_app.cpp (set-up, the frame
// loop, the drag benchmark), editor_documents.cpp (opening, recovery, actions, saving),
// editor_panel.cpp (the side panel and the dialogs) and editor_input.cpp (keys, mouse, painting,
// handle drags, overlays). Internal to the editor: only those files include it. What can be
// tested without a window lives in the parts it uses (edit_tools.h, handle_drag.h, gizmo.h, ...).
#include "gui/editor_app.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <nlohmann/json.hpp>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>
#include <algorithm>
#include <array>
#include <atomic>
#include <csignal>
#include <cctype>
#include <chrono>
#include <cmath>
#include <deque>
#include <fstream>
#include <iostream>
#include <mutex>
#include <numbers>
#include <span>
#include <sstream>
#include <thread>
#include <tuple>
#include "commands/cli_support.h"
#include "model/document.h"
#include "model/background_task.h"
#include "gui/edit_tools.h"
#include "gui/frame_statistics.h"
#include "gui/handle_drag.h"
#include "gui/gizmo.h"
#include "gui/input_queue.h"
#include "gui/motion_detail.h"
#include "gui/pose_editor.h"
#include "gui/profiler_panel.h"
#include "gui/recent_files.h"
#include "gui/recovery.h"
#include "gui/scene_slices.h"
#include "gui/restore_prompt.h"
#include "gui/synthetic_drag.h"
#include "gui/view_navigation.h"
#include "gui/view_picking.h"
#include "model/transfer_state.h"
#include "gui/transfer_view.h"
#include "gui/widgets.h"
#include "hdeform/atomic_file.h"
#include "hdeform/constraint_io.h"
#include "hdeform/engine/frame_slots.h"
#include "hdeform/engine/image_io.h"
#include "hdeform/engine/mesh_renderer.h"
#include "hdeform/engine/palette.h"
#include "hdeform/engine/proxy_mesh.h"
#include "hdeform/engine/swapchain_target.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "hdeform/trace.h"
#include "model/mesh_picker.h"
#include "commands/render_support.h"
#include "model/selection.h"
#include "hdeform/stopwatch.h"

namespace hdeform::cli::gui {

using Clock = std::chrono::steady_clock;

inline constexpr float kPanelWidth = 330.0f;
inline constexpr double kRecoveryInterval = 3.0;  // seconds between periodic recovery writes
inline constexpr double kProgressDelay = 0.5;     // show progress for work longer than this
inline constexpr double kMaxLatchMs = 20.0;       // the longest a frame waits for a solve ("latch" pacing)
inline constexpr int kRefineAfterRestMs = 150;     // "latch": while a handle or value is held, refinement once its input has rested this long
inline constexpr int kRefinementFrameMs = 100;     // "latch": a settling shape is drawn at most this often

inline std::string lowercase_first(std::string text) {
  if (!text.empty()) text[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(text[0])));
  return text;
}

// Every shortcut, shown by the help overlay (F1).
inline constexpr std::pair<const char*, const char*> kShortcuts[] = {
    {"Right drag / Alt+left drag", "orbit"},
    {"Middle drag / Shift+right drag", "pan"},
    {"Wheel", "zoom"},
    {"F", "fit the view to the mesh"},
    {"1 / 2 / 3", "paint region of interest / fixed / handle"},
    {"E", "erase instead of paint"},
    {"Alt+Z", "paint through: the brush and lasso reach the back too"},
    {"L", "lasso instead of brush"},
    {"[ / ]", "smaller / larger brush"},
    {"C, then click", "paint the connected part under the cursor"},
    {"I", "invert the current layer"},
    {"= / -", "grow / shrink the current layer by one ring"},
    {"N", "new handle"},
    {"Tab", "next handle"},
    {"Ctrl+Delete", "remove the active handle"},
    {"G / R / S / T", "move / rotate / scale / twist the active handle"},
    {"X / Y / Z", "move or rotate: along / about that axis only (again: free)"},
    {"Shift+X / Y / Z", "move in the plane normal to that axis"},
    {"X / Y / Z / V (twist)", "twist axis x / y / z / view"},
    {"Gizmo: axis / square / ring", "drag along the axis / in the plane / about the axis"},
    {"0", "reset the handles to rest"},
    {"A", "apply: the result becomes the rest shape"},
    {"Ctrl+Z / Ctrl+Shift+Z", "undo / redo"},
    {"Ctrl+O", "open a mesh (.obj, .ply, .off, .stl) or a session (.json)"},
    {"Ctrl+S / Ctrl+Shift+S", "save / save as (the mesh, and its session beside it)"},
    {"W / H / K", "wireframe / harmonic field / vertex classes"},
    {"P", "profiler: the last updates, iterations and frames by stage"},
    {"F12 / Shift+F12", "screenshot of the view / of the whole window"},
    {"F1 / Esc", "this help / close it"},
    {"Ctrl+T", "transfer mode: source and target side by side"},
    {"Transfer: click, click", "a vertex on one mesh, then its counterpart: a marker pair"},
    {"Transfer: drag / Del / Esc", "move a marker / delete the selected pair / cancel"},
    {"Transfer: F5 / Space / Left, Right", "compute / play, pause / previous, next pose"},
    {"Transfer: Ctrl+S, Ctrl+Z", "save the markers, undo a marker change"},
    {"Ctrl+Q", "quit"},
    {"Unsaved changes? Enter / D / Esc", "save, then go on / discard / cancel"},
};

inline std::string session_path_for(const std::string& obj_path) {
  std::filesystem::path path(obj_path);
  if (mesh_format_of(path)) path.replace_extension("");
  return path.string() + ".session.json";
}

inline std::string percentile_text(std::vector<double> values) {
  if (values.empty()) return "-";
  const Summary summary = summarize(std::move(values));
  char text[64];
  std::snprintf(text, sizeof text, "%.1f ms (p95 %.1f)", summary.median, summary.p95);
  return text;
}

class EditorApp {
 public:
  explicit EditorApp(const EditorOptions& options) : options_(options) {}
  ~EditorApp() { shutdown(); }

  int run();

 private:
  enum class Mode { Edit, Transfer };

  // ---- set-up --------------------------------------------------------------------------------

  void create_window();
  static void queue_input(GLFWwindow* window, InputEvent event);
  void create_renderer();

  // A frame's geometry is taken when the frame is prepared. With two frames in flight it is
  // prepared while the previous one renders, so what it shows is a frame older than it could be;
  // on a GPU that buys throughput, on a CPU device (where "the GPU" is these same cores) it only
  // adds latency (measured on lavapipe with buddha-206k). HDEFORM_FRAMES_IN_FLIGHT overrides.
  uint32_t frames_in_flight() const;
  // Under validation only the rendering thread calls Vulkan (presenting, timing frames).
  bool single_threaded_vulkan() const;
  void set_mode(Mode mode);
  void shutdown();

  // ---- documents ------------------------------------------------------------------------------

  void start_from_options();

  // Transfer mode's recovery file, beside the session's.
  std::filesystem::path transfer_recovery_path() const;
  void remove_recovery_files();
  void restore_transfer_mode();

  // Transfer mode's state goes to its recovery file whenever it changes (small: written here).
  void write_transfer_recovery();
  void offer_restore();
  void answer_restore(RestoreChoice choice);
  void restore_recovery();

  // The document the command line asked for.
  void start_requested_document();

  // A pose about the handle's centroid; with `target`, the pose that reaches it (rotation and
  // uniform scale; a 3×4 matrix's stretch is dropped, as the gizmo has none).
  static HandleTransform pose_for(const std::vector<int>& vertices, const Mesh& mesh, const std::optional<HandleTransform>& target);

  // `recovered`: the session comes from the recovery file, work that no file holds yet.
  template <class Load>
  void start_load(const std::string& what, Load load, bool recovered = false) {
    DeformerOptions document_options;
    document_options.resolution = options_.resolution;
    document_options.base_vertices = options_.base_vertices;
    document_options.precision = options_.precision;
    drop_staged();  // a mesh read before is no longer wanted
    load_.start("Loading " + what, [load, document_options, recovered] {
      auto files = load();  // (session, mesh) or (session, mesh, a problem with the lists given beside the mesh)
      Loaded loaded;
      loaded.session = std::move(std::get<0>(files));
      if constexpr (std::tuple_size_v<decltype(files)> == 3) loaded.problem = std::move(std::get<2>(files));
      // Replaying applied stages and the checks run here, off the frame loop; the publisher is
      // attached when the document is installed. The document takes the mesh itself.
      loaded.document = std::make_unique<Document>(loaded.session, std::move(std::get<1>(files)), document_options, Document::Publish{});
      // Restored work is unsaved: Open, a drop and Quit ask before they discard it.
      if (recovered) loaded.document->mark_unsaved();
      loaded.scene = prepare_scene(loaded.document->shared_rest());
      loaded.session_digest = session_digest(loaded.document->session());
      return loaded;
    }, [] { glfwPostEmptyEvent(); });
  }

  // What drawing a mesh needs that no device call does, made while it loads: at 3.3 million
  // triangles these held the frame that installs the mesh for 1.5 s (the snapshots' buffers, the
  // normals' incidence, the first publication, the test for a closed mesh).
  struct PreparedScene {
    std::unique_ptr<engine::GeometryExchange> exchange;
    std::unique_ptr<engine::GeometryPublisher> publisher;  // writes into `exchange`; the rest shape published
    engine::Bounds bounds;
    bool closed = false;
    // The vectors sync_view() hands the renderer, sized for the mesh and their pages written here
    // (at 13 million triangles, 53 MB of first writes, most of 0.26 s of the frame after install).
    std::vector<uint32_t> view_classes;
    std::vector<float> view_field;
  };
  static PreparedScene prepare_scene(const std::shared_ptr<const Mesh>& rest);

  struct Loaded {
    Session session;
    std::unique_ptr<Document> document;
    std::string problem;  // a list given with the mesh that could not be used (the mesh opened without it)
    PreparedScene scene;
    std::string session_digest;  // for the `opened` event (0.2 s of the install frame at 13M triangles)
  };

  // A mesh read, whose renderer's buffers are written on a thread of their own (mesh_buffers.h:
  // at 13 million triangles their first writes held the install frame for 1.5 s); installed when
  // they are.
  struct Staged {
    Loaded loaded;
    std::unique_ptr<engine::MeshBuffers> buffers;
    bool announced = false;  // the load's progress was on screen: so is this
    std::shared_ptr<std::atomic<bool>> stop = std::make_shared<std::atomic<bool>>(false);
    std::shared_ptr<std::atomic<double>> done = std::make_shared<std::atomic<double>>(0.0);  // share written
  };

  // Installs the mesh staged, once its buffers are written; takes a finished load and stages it.
  void finish_load();
  void stage(Loaded loaded, bool announced);
  // Stops writing the staged mesh's buffers and lets it go (a new load, Quit).
  void drop_staged();
  // A mesh or session that could not be opened: said in the window (and the benchmark ends).
  void report_open_failure(const std::string& failure);
  // Closes the document (nothing more is published) and lets go of it on a thread of its own.
  void retire_document();
  void install(Loaded loaded_document, std::unique_ptr<engine::MeshBuffers> buffers);
  // install(), then the problem with the lists given beside the mesh, if any, shown.
  void install_with_problem(Loaded loaded, std::unique_ptr<engine::MeshBuffers> buffers);

  // --up, when given (transfer mode guesses each mesh's without it).
  std::optional<engine::UpAxis> chosen_up_axis() const;
  engine::UpAxis up_axis() const { return up_axis_; }

  // The share of the window's width the side panel covers (the view is centred in the rest).
  float panel_fraction() const;
  void adjust_camera(bool reset_angles);
  // Opens a mesh or a session (Ctrl+O, a drop, a recent file), asking first when that would
  // discard unsaved edits.
  void open_path(const std::string& path);
  void open_now(const std::string& path);

  // ---- the frame --------------------------------------------------------------------------------

  // Until the device can take the next frame, input keeps flowing: a handle drag changes the
  // pose the moment the move arrives.
  //
  // Solve pacing. "free": each input posts its solve at once and every frame shows whatever
  // result is newest; no frame ever waits. "latch", the default on a CPU device: there the
  // rasterizer and the solver share the same cores, and solving while a frame renders slows both
  // (buddha-206k on lavapipe, 2 cores: 23 fps and 82 ms from input to screen). Instead the inputs
  // taken while a frame renders are solved the moment the device is free, and the next frame
  // waits for that result for at most a short latch (twice the recent update time + 2 ms, never
  // more than 20 ms); if it has not landed by then, the frame shows the previous result (28 fps,
  // 56 ms). The solve still runs on the pipeline's thread, never on this one.
  void wait_for_device();
  void take_input_while_waiting();

  // A pose changed by input: posted now ("free"), or when the device is next free ("latch").
  void note_pose_input(Clock::time_point event_time) { note_pose_input(std::span(&event_time, 1)); }
  void note_pose_input(std::span<const Clock::time_point> events);

  // Posts the solve of the current poses for the inputs not posted yet; returns its request (0: none).
  std::uint64_t post_pending_solve();

  void step();

  // On stdout, for scripts and tests that drive the editor.
  void announce_solver_state();
  void sync_view();
  void render(ImDrawData* draw_data);

  // The profiler's bars: the document's updates and iterations, and each frame's processor time
  // joined with the device's time for it once that is known.
  void take_profile();
  void note_frame_work(double cpu_ms);

  // Frames the device finished (timed by a thread that waits on a timeline semaphore): the
  // frame cadence while the loop runs without idling, and for the first frame that shows a
  // request's result, the latency from the input event that caused it.
  void note_finished_frames();

  bool view_only_screenshot() const { return screenshot_requested_ && !screenshot_with_panel_; }

  void write_screenshot(const engine::Pixels& pixels);

  // ---- the panel ----------------------------------------------------------------------------------

  // The panel: its controls scroll, and below them the status, the error and the live figures
  // stay in view at any window height.
  void draw_panel();
  void draw_footer();
  std::vector<std::string> shown_notes() const;
  // Why the solver could not be set up for this selection, or could not answer the current poses
  // ("" when it could), in the footer.
  std::string solver_failure() const;
  void draw_controls();
  void draw_pose_editor();

  // Where the pose fields are (Move, Axis, Angle, Scale: one row each), on stdout whenever that
  // changes, for scripts that type into them.
  void announce_pose_fields();
  // ... and where the Refine checkbox is (the last item drawn), the same way.
  void announce_refine_toggle();
  void draw_dialogs();

  // The Open box starts from something that exists: the open mesh, else the folder of the file
  // last asked for, else the working folder.
  void request_open();
  void request_save_as();

  // A file that could not be opened (from the command line, Open, a drop or a session): the
  // reason in full, in the window, with the previous document (if any) still open behind it.
  void draw_open_failure();
  // A save that failed: the reason, and Save as.
  void draw_save_failure();
  // Where the session solves (Solve on, Base vertices, Single-precision factor), and the question
  // asked before a scan is solved on every vertex.
  void draw_solve_choice();
  void draw_exact_confirmation();
  // "every vertex", "a base of 150000 vertices", with ", single-precision factor" where so.
  std::string solve_site_text(const Document::SolveChoice& choice) const;
  void change_solve_choice(const Document::SolveChoice& choice);

  // ---- actions ------------------------------------------------------------------------------------

  // A finished action: one undo step named `what`, the view refreshed, the recovery file written.
  void commit_action(const std::string& what);

  template <class Act>
  void finish_action(const std::string& what, Act act) {
    if (!document_) return;
    act();
    post_request(Clock::now());
    commit_action(what);
  }

  // `verb` ("invert") applied to the current tool's layer.
  template <class Act>
  void layer_action(const char* verb, Act act) {
    if (!document_ || !is_paint_tool(tools_.tool)) return;
    finish_action(std::string(verb) + " " + layer_name(), [&] { act(layer_of(tools_.tool)); });
  }

  // The current paint tool's layer, as the status line names it.
  std::string layer_name() const;
  void undo();
  void redo();
  void after_history_step(const std::string& what);
  void apply();

  // Without a solver (no handle) nothing publishes: show the rest shape.
  void publish_rest_if_needed();

  // Posts the current poses, answering the inputs that led to them (their times, for latency).
  std::uint64_t post_request(std::span<const Clock::time_point> events);
  std::uint64_t post_request(Clock::time_point event_time) { return post_request(std::span(&event_time, 1)); }
  // A handle is being dragged (by the pointer, or the benchmark's synthetic drag).
  bool handle_dragged() const { return (dragging_ && !is_paint_tool(tools_.tool)) || benchmark_ != nullptr; }

  void post_recovery();
  // Saves the result for the current poses to `path` (and its session beside it) once the shape
  // on screen has settled: at once when it has, else when the refinement stops (the status line
  // says so meanwhile). A failure opens the "Could not save" dialog.
  void save(const std::string& path);
  void finish_pending_save();
  // The files are written on a thread of its own (a scan's OBJ takes seconds) while the window
  // shows the progress; input waits in its queue meanwhile, so nothing changes what is saved.
  void start_save(const std::string& path);
  void finish_save();
  void fail_save(const std::string& why);  // the "Could not save" dialog, an `error` event
  bool saving() const { return save_task_.running(); }
  // Where Save writes unless --output or Save as said otherwise: the folder of the last save, else
  // the working folder; never silently beside the input, which may be read-only or shared.
  std::string default_output_path() const;

  // Actions that would discard unsaved work (the edits, transfer mode's markers) ask first.
  struct PendingAction {
    enum class Kind { Quit, Open } kind;
    std::string path;  // Open: the mesh or session
    std::string describe() const;
  };
  UnsavedWork unsaved_work() const;
  void ask_or_run(const PendingAction& action);
  void run_action(const PendingAction& action);
  void answer_unsaved(UnsavedChoice choice);

  // The state goes to the recovery file, synchronously, and stays there for the next start.
  void quit_on_signal(int signal);
  void request_quit();

  // The rest shape's diameter: measured once per rest shape (several widgets ask every frame, and
  // at 1.6 million vertices each measure took 4 ms).
  float scene_size() const {
    if (!document_) return 1.0f;
    const Mesh* rest = &document_->rest();
    if (rest != scene_size_of_) {
      scene_size_ = 2.0f * engine::Bounds::of(rest->positions).radius();
      scene_size_of_ = rest;
    }
    return scene_size_;
  }
  mutable const Mesh* scene_size_of_ = nullptr;
  mutable float scene_size_ = 1.0f;

  // ---- input ------------------------------------------------------------------------------------------

  void handle_keys();

  // Whether `key` was pressed since the last frame with exactly the modifiers `mods` (of Ctrl,
  // Shift and Alt).
  bool pressed(int key, int mods = 0) const;
  DialogKeys dialog_keys() const {
    return {pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER), pressed(GLFW_KEY_ESCAPE), pressed(GLFW_KEY_D)};
  }
  Eigen::ParametrizedLine<float, 3> cursor_ray(const ImVec2& cursor) const;

  // The whole shape on screen (the renderer's newest snapshot), or nullptr.
  const engine::GeometrySnapshot* shown_snapshot();
  // The same, with the picker following it as closely as `need` asks.
  const engine::GeometrySnapshot* shown_geometry(ViewPicker::Need need = ViewPicker::Need::Exact);
  void handle_mouse();

  // Applies the cursor's move since the last one applied (from the frame or from the wait for the
  // device: each move counts once).
  void continue_handle_drag(const ImVec2& cursor, Clock::time_point event_time);

  // The brush on screen: its centre and radius in window pixels, its world size at the cursor's
  // depth on the mesh (painting through, at the view target's depth where the cursor misses it).
  std::optional<std::pair<ImVec2, float>> brush_on_screen(const ImVec2& mouse, ViewPicker::Need need = ViewPicker::Need::Exact);
  // Paints under the brush at `mouse` (a stroke's first stamp), or along the way from the last
  // stamp through this frame's pointer positions.
  void paint_brush(const ImVec2& mouse);
  void paint_brush_along(std::span<const ImVec2> path);
  void paint_stamps(std::span<const ImVec2> stamps);
  void extend_lasso(std::span<const ImVec2> path);
  void paint_lasso();
  void paint_connected(const ImVec2& mouse);

  // Moves the active handle by a mouse drag (or the benchmark's synthetic one).
  void drag_handle(const ImVec2& mouse, const ImVec2& delta, Clock::time_point event_time);
  std::optional<Eigen::Vector2f> project_to_window(const Eigen::Vector3f& point) const;
  ImVec2 project(const Eigen::Vector3f& point) const;
  void draw_overlays();

  // The gizmo of the active handle for the move and rotate tools: its axes turned with the
  // handle, 8% of the scene long, kept inside the view.
  void lay_out_gizmo();

  // ---- the drag benchmark ---------------------------------------------------------------------------

  // Drags the first handle back and forth along its pose (from the identity to the pose the
  // command line gave, or a default bend) through the same code as a mouse drag, then reports
  // frame times and input-to-screen latency and quits. The input comes like a mouse's: a thread
  // produces timestamped moves at 100 Hz, independent of the frames, and the loop takes them
  // whenever it gets to them; each move's latency runs from its timestamp to the first frame
  // that shows a solve including it.
  // With refinement on, the drag ends with a release at the target pose, and the report adds
  // how long the refinement then takes to settle on screen ("settle").
  void benchmark_step();
  void take_benchmark_input();
  nlohmann::json drag_figures(double seconds) const;
  void finish_benchmark();

  // ---- state ------------------------------------------------------------------------------------------

  EditorOptions options_;
  GLFWwindow* window_ = nullptr;
  bool glfw_started_ = false;
  bool imgui_started_ = false;
  bool imgui_vulkan_started_ = false;
  VkDescriptorPool imgui_pool_ = VK_NULL_HANDLE;
  std::unique_ptr<engine::VulkanContext> context_;
  std::unique_ptr<engine::SwapchainTarget> target_;
  std::unique_ptr<engine::FrameSlots> slots_;
  std::unique_ptr<engine::MeshRenderer> renderer_;
  std::unique_ptr<engine::GeometryExchange> exchange_;
  std::unique_ptr<engine::GeometryPublisher> publisher_;
  std::unique_ptr<Document> document_;
  ViewPicker picker_;  // follows the geometry on screen (shown_geometry())
  std::unique_ptr<RecoveryWriter> recovery_;

  BackgroundTask<Loaded> load_;  // reading a mesh or session and replaying it
  std::optional<Staged> staged_;  // read, its renderer's buffers being written (stage_)
  BackgroundTask<bool> stage_;     // writing them: false when stopped
  BackgroundTask<Eigen::MatrixXi> proxy_task_;  // simplifying the mesh just opened (CPU device)
  BackgroundTask<bool> retiring_;               // letting go of the document another one replaced
  MotionDetail motion_detail_;
  std::size_t slice_triangles_ = 0;  // a picture of more triangles is drawn in slices (scene_slices.h); 0: whole
  int scene_ramp_ = 0;               // the ramp of the picture being drawn in slices
  bool panel_behind_picture_ = false;  // the last frame completed a picture in slices after its panel was made
  std::uint64_t announced_refinement_ = 0;  // the request whose settled refinement was announced last
  std::uint64_t announced_failure_ = 0;     // the request whose failed answer was announced last
  Eigen::Index proxy_triangle_count_ = 0;
  // Starts simplifying a newly opened mesh, on a CPU device with --proxy auto; installs the proxy
  // when it is done (finish_proxy, each frame).
  void start_proxy();
  void finish_proxy();
  // Builds the picker ahead of the first pick where the cores have nothing else to do.
  void prepare_picking();
  // What moves the geometry this frame: the user (a handle dragged, the view turned), a new solve,
  // or nothing.
  MotionDetail::Motion view_motion();
  Clock::time_point build_started_{};

  engine::Camera camera_;
  engine::UpAxis up_axis_ = engine::UpAxis::Z;
  engine::RenderSettings settings_;
  std::string mesh_name_;
  std::string output_path_;
  char path_buffer_[1024] = {};
  std::string status_;
  std::string error_message_;
  std::unique_ptr<RecentFiles> recent_;     // beside the recovery file
  std::vector<std::string> recent_shown_;    // while the Open box is up
  std::string open_failure_;
  std::vector<std::string> solver_warnings_;  // the ready deformer's findings, shown in the panel
  std::string last_open_request_;  // the path last given to Open, a drop or the command line  // shown in the "Could not open" dialog until dismissed
  std::vector<std::string> dropped_paths_;
  Mode mode_ = Mode::Edit;
  std::unique_ptr<TransferView> transfer_;

  EditTools tools_;
  float brush_radius_ = 0.02f;
  bool dragging_ = false;
  bool camera_drag_ = false;
  ImVec2 drag_cursor_{};  // the cursor position the handle drag has applied up to
  std::vector<ImVec2> stroke_;  // the lasso's points
  ImVec2 last_stamp_{};          // where the brush last painted in this stroke
  bool view_dirty_ = true;
  std::vector<uint32_t> view_classes_;  // what sync_view hands the renderer, kept for the next call
  std::vector<float> view_field_;
  struct KeyPress {
    int key;
    int mods;
  };
  InputQueue input_;  // from the window's callbacks, a frame's worth at a time
  ImGuiInputFeed imgui_input_;
  std::vector<KeyPress> frame_keys_;   // this frame's
  std::vector<ImVec2> frame_pointer_path_;  // this frame's pointer positions, oldest first: a stroke follows each

  bool show_help_ = false;
  bool keep_recovery_ = false;
  std::uint64_t transfer_recovery_version_ = 0;  // the transfer state's version last written  // quit by a signal: the recovery file is what the next start offers
  std::optional<RestoreOffer> restore_offer_;  // the restore prompt is open
  std::string after_open_note_;                // said in the status line once the next document opens
  bool open_dialog_ = false;
  bool save_dialog_ = false;
  std::optional<Document::SolveChoice> confirm_exact_;  // the question before solving on every vertex is open
  int base_vertices_field_ = 0;                          // the Base vertices field while it is typed in
  bool base_vertices_editing_ = false;
  std::optional<PendingAction> asked_;       // the unsaved-changes question is open for it
  std::optional<PendingAction> after_save_;  // runs once the save it waits for is written
  std::optional<std::string> pending_save_;  // a save waiting for the shape to settle
  BackgroundTask<std::string> save_task_;     // writing a save; its result is the positions' digest
  std::string saving_path_;
  Session saving_session_;  // what the save being written holds
  std::string save_failure_;                 // shown in the "Could not save" dialog until dismissed
  std::filesystem::path save_folder_;        // of the last save ("": none yet)
  bool quit_ = false;
  int exit_code_ = 0;
  std::array<float, 4> announced_pose_fields_{};
  std::array<float, 4> announced_refine_toggle_{};
  HandleGizmo gizmo_;
  GizmoPart gizmo_drag_ = GizmoPart::None;  // the part the current drag started on
  bool screenshot_requested_ = false;
  bool screenshot_with_panel_ = false;  // Shift+F12: the window as it looks, panel and dialogs too
  int screenshots_ = 0;
  bool recovery_dirty_ = false;
  Clock::time_point last_recovery_ = Clock::now();

  // Frame and latency figures.
  FrameStatistics statistics_;
  bool waited_idle_ = false;    // the loop waited for events before this frame
  std::uint64_t shown_tag_ = 0;  // the geometry the frame shows (the request it answers)
  bool scene_shows_transfer_ = false;  // the scene the target keeps is the transfer views'
  std::uint64_t frames_drawn_ = 0;
  std::uint64_t scene_frames_ = 0;     // of those, the frames that drew the scene; the others showed it as kept
  Clock::time_point last_input_ = Clock::now();
  std::vector<Clock::time_point> unposted_events_;  // inputs whose solve is not posted yet
  bool latch_solves_ = false;
  ProfilerPanel profiler_;
  bool show_profiler_ = false;
  std::deque<std::pair<std::uint64_t, double>> frame_work_;  // frame, processor milliseconds
  std::uint64_t last_submitted_frame_ = 0;
  double last_update_seen_ = 0.0;
  std::unique_ptr<SyntheticDrag> benchmark_;  // --benchmark-drag, while it runs
  bool benchmark_done_ = false;
  HandleTransform benchmark_target_;
  nlohmann::json drag_report_;                         // the drag's figures, while the release settles
  std::optional<Clock::time_point> settle_started_;    // the release
  static constexpr double kSettleTimeout = 120.0;      // seconds
};

}  // namespace hdeform::cli::gui

#include "gui/editor_app.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>

#include <algorithm>
#include <array>
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

#include "cli_support.h"
#include "document.h"
#include "gui/background_task.h"
#include "gui/edit_tools.h"
#include "gui/frame_statistics.h"
#include "gui/handle_drag.h"
#include "gui/gizmo.h"
#include "gui/input_queue.h"
#include "gui/pose_editor.h"
#include "gui/profiler_panel.h"
#include "gui/recovery.h"
#include "gui/restore_prompt.h"
#include "gui/synthetic_drag.h"
#include "gui/view_navigation.h"
#include "transfer_state.h"
#include "gui/transfer_view.h"
#include "gui/widgets.h"
#include "hdeform/atomic_file.h"
#include "hdeform/constraint_io.h"
#include "hdeform/engine/frame_slots.h"
#include "hdeform/engine/image_io.h"
#include "hdeform/engine/mesh_renderer.h"
#include "hdeform/engine/palette.h"
#include "hdeform/engine/swapchain_target.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "hdeform/trace.h"
#include "mesh_picker.h"
#include "render_support.h"
#include "selection.h"
#include "hdeform/stopwatch.h"

namespace hdeform::cli {
namespace {

using Clock = std::chrono::steady_clock;

constexpr float kPanelWidth = 330.0f;
constexpr double kRecoveryInterval = 3.0;  // seconds between periodic recovery writes
constexpr double kProgressDelay = 0.5;     // show progress for work longer than this
constexpr double kMaxLatchMs = 20.0;       // the longest a frame waits for a solve ("latch" pacing)
constexpr int kRefineAfterRestMs = 150;     // "latch": refinement once the input has rested this long



std::string lowercase_first(std::string text) {
  if (!text.empty()) text[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(text[0])));
  return text;
}



// Every shortcut, shown by the help overlay (F1).
constexpr std::pair<const char*, const char*> kShortcuts[] = {
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
    {"Ctrl+O", "open a mesh (.obj) or a session (.json)"},
    {"Ctrl+S / Ctrl+Shift+S", "save / save as (the mesh, and its session beside it)"},
    {"W / H / K", "wireframe / harmonic field / vertex classes"},
    {"P", "profiler: the last updates, iterations and frames by stage"},
    {"F12 / Shift+F12", "screenshot of the view / of the whole window"},
    {"F1", "this help"},
    {"Ctrl+T", "transfer mode: source and target side by side"},
    {"Transfer: click, click", "a vertex on one mesh, then its counterpart: a marker pair"},
    {"Transfer: drag / Del / Esc", "move a marker / delete the selected pair / cancel"},
    {"Transfer: F5 / Space / Left, Right", "compute / play, pause / previous, next pose"},
    {"Transfer: Ctrl+S, Ctrl+Z", "save the markers, undo a marker change"},
    {"Ctrl+Q", "quit"},
};

std::string session_path_for(const std::string& obj_path) {
  std::filesystem::path path(obj_path);
  if (path.extension() == ".obj") path.replace_extension("");
  return path.string() + ".session.json";
}

std::string percentile_text(std::vector<double> values) {
  if (values.empty()) return "-";
  const Summary summary = summarize(std::move(values));
  char text[64];
  std::snprintf(text, sizeof text, "%.1f ms (p95 %.1f)", summary.median, summary.p95);
  return text;
}

// SIGTERM, SIGINT and SIGHUP ask the editor to write its recovery file and quit: the next start
// offers it. The handler only records the signal; the frame loop (which wakes at least every
// 0.25 s) acts on it.
volatile std::sig_atomic_t quit_signal = 0;
extern "C" void record_quit_signal(int signal) { quit_signal = signal; }

class QuitSignals {
 public:
  QuitSignals() {
    quit_signal = 0;
    struct sigaction action {};
    action.sa_handler = record_quit_signal;
    sigemptyset(&action.sa_mask);
    for (std::size_t k = 0; k < kSignals.size(); ++k) sigaction(kSignals[k], &action, &previous_[k]);
  }
  ~QuitSignals() {
    for (std::size_t k = 0; k < kSignals.size(); ++k) sigaction(kSignals[k], &previous_[k], nullptr);
  }
  QuitSignals(const QuitSignals&) = delete;
  QuitSignals& operator=(const QuitSignals&) = delete;
  static int received() { return quit_signal; }

 private:
  static constexpr std::array<int, 3> kSignals{SIGTERM, SIGINT, SIGHUP};
  std::array<struct sigaction, 3> previous_{};
};

class EditorApp {
 public:
  explicit EditorApp(const EditorOptions& options) : options_(options) {}
  ~EditorApp() { shutdown(); }

  int run() {
    if (!options_.trace.empty()) trace::start();
    trace::name_thread("main");
    create_window();
    create_renderer();
    start_from_options();
    const QuitSignals signals;
    while (!quit_) {
      if (QuitSignals::received() != 0) {
        quit_on_signal(QuitSignals::received());
        break;
      }
      const bool busy = !input_.empty() || dragging_ || load_.running() || benchmark_ || screenshot_requested_ || (transfer_ && transfer_->busy()) ||
                        (document_ && (document_->solver_state() == Document::SolverState::Building ||
                                       document_->last_published_request() != shown_tag_));
      if (busy) glfwPollEvents();
      else {
        glfwWaitEventsTimeout(0.25);
        waited_idle_ = true;
      }
      if (glfwWindowShouldClose(window_)) {
        glfwSetWindowShouldClose(window_, GLFW_FALSE);
        request_quit();
      }
      {
        const trace::Scope traced("frame", "frame");
        const auto began = Clock::now();
        step();
        note_frame_work(milliseconds_between(began, Clock::now()));
      }
      {
        const trace::Scope traced("wait for the device and the solve", "frame");
        wait_for_device();
      }
      if (trace::enabled()) trace::counter("resident memory (MB)", resident_mb());
    }
    if (recovery_ && !keep_recovery_) {
      recovery_->discard();
      std::error_code ignored;
      std::filesystem::remove(transfer_recovery_path(), ignored);
    }
    if (!options_.trace.empty()) {
      trace::stop();
      try {
        trace::write(options_.trace);
        print_json_line({{"event", "trace"}, {"path", options_.trace}});
      } catch (const std::exception& error) {
        std::cerr << "hdeform: error: " << error.what() << '\n';
        exit_code_ = 1;
      }
    }
    return exit_code_;
  }

 private:
  enum class Mode { Edit, Transfer };

  // ---- set-up --------------------------------------------------------------------------------

  void create_window() {
    if (!glfwInit()) throw engine::RenderError("cannot open a window (no display? set DISPLAY, or use hdeform render for pictures)");
    glfw_started_ = true;
    if (!glfwVulkanSupported()) throw engine::RenderError("the window system offers no Vulkan surface");
    const auto [width, height] = parse_size(options_.size, "--size", 320, 240, 8192);
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    window_ = glfwCreateWindow(static_cast<int>(width), static_cast<int>(height), "hdeform", nullptr, nullptr);
    if (window_ == nullptr) throw engine::RenderError("cannot create a window");
    glfwSetWindowUserPointer(window_, this);
    // Input goes to a queue that hands ImGui one frame's worth at a time (input_queue.h); ImGui's
    // backend installs no callbacks of its own.
    glfwSetCursorPosCallback(window_, [](GLFWwindow* window, double x, double y) {
      trace::instant("pointer moved", "input");
      queue_input(window, {.kind = InputEvent::Kind::Move, .x = x, .y = y});
    });
    glfwSetKeyCallback(window_, [](GLFWwindow* window, int key, int, int action, int mods) {
      trace::instant("key", "input");
      queue_input(window, {.kind = InputEvent::Kind::Key, .code = key, .action = action, .mods = mods});
    });
    glfwSetCharCallback(window_, [](GLFWwindow* window, unsigned character) {
      queue_input(window, {.kind = InputEvent::Kind::Character, .character = character});
    });
    glfwSetMouseButtonCallback(window_, [](GLFWwindow* window, int button, int action, int mods) {
      trace::instant("button", "input");
      queue_input(window, {.kind = InputEvent::Kind::Button, .code = button, .action = action, .mods = mods});
    });
    glfwSetScrollCallback(window_, [](GLFWwindow* window, double x, double y) {
      trace::instant("scroll", "input");
      queue_input(window, {.kind = InputEvent::Kind::Scroll, .x = x, .y = y});
    });
    glfwSetWindowFocusCallback(window_, ImGui_ImplGlfw_WindowFocusCallback);
    glfwSetCursorEnterCallback(window_, ImGui_ImplGlfw_CursorEnterCallback);
    glfwSetDropCallback(window_, [](GLFWwindow* window, int count, const char** paths) {
      auto* app = static_cast<EditorApp*>(glfwGetWindowUserPointer(window));
      app->dropped_paths_.assign(paths, paths + count);
    });
  }

  static void queue_input(GLFWwindow* window, InputEvent event) {
    event.time = Clock::now();
    auto* app = static_cast<EditorApp*>(glfwGetWindowUserPointer(window));
    app->input_.push(event);
    app->last_input_ = event.time;
  }

  void create_renderer() {
    engine::ContextOptions context_options;
    context_options.device = options_.device;
    context_options.validation = options_.validation;
    uint32_t count = 0;
    const char** extensions = glfwGetRequiredInstanceExtensions(&count);
    context_options.instance_extensions.assign(extensions, extensions + count);
    context_options.create_surface = [this](VkInstance instance) {
      VkSurfaceKHR surface = VK_NULL_HANDLE;
      engine::check(glfwCreateWindowSurface(instance, window_, nullptr, &surface), "glfwCreateWindowSurface");
      return surface;
    };
    context_ = std::make_unique<engine::VulkanContext>(context_options);
    const int samples = options_.samples > 0 ? options_.samples : context_->interactive_samples();
    target_ = std::make_unique<engine::SwapchainTarget>(
        *context_,
        [this] {
          int width = 0, height = 0;
          glfwGetFramebufferSize(window_, &width, &height);
          return VkExtent2D{static_cast<uint32_t>(width), static_cast<uint32_t>(height)};
        },
        samples, false, true);
    slots_ = std::make_unique<engine::FrameSlots>(*context_, frames_in_flight());
    slots_->enable_completion_times();
    latch_solves_ = options_.pacing == "latch" || (options_.pacing == "auto" && context_->is_cpu_device());
    renderer_ = std::make_unique<engine::MeshRenderer>(*context_, target_->render_pass(), target_->format(), slots_->count());
    transfer_ = std::make_unique<TransferView>(*context_, target_->render_pass(), target_->format(), slots_->count(), up_axis());

    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    imgui_started_ = true;
    ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini beside the user's files
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForVulkan(window_, false);
    const VkDescriptorPoolSize pool_size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 16};
    VkDescriptorPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    pool_info.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    pool_info.maxSets = 16;
    pool_info.poolSizeCount = 1;
    pool_info.pPoolSizes = &pool_size;
    engine::check(vkCreateDescriptorPool(context_->device(), &pool_info, nullptr, &imgui_pool_), "vkCreateDescriptorPool");
    ImGui_ImplVulkan_InitInfo info{};
    info.Instance = context_->instance();
    info.PhysicalDevice = context_->physical_device();
    info.Device = context_->device();
    info.QueueFamily = context_->queue_family();
    info.Queue = context_->queue();
    info.DescriptorPool = imgui_pool_;
    info.MinImageCount = 2;
    info.ImageCount = 3;  // ImGui cycles its buffers over this many frames: more than frames in flight
    info.MSAASamples = target_->format().samples;
    info.CheckVkResultFn = [](VkResult result) { engine::check(result, "Dear ImGui (Vulkan)"); };
    ImGui_ImplVulkan_Init(&info, target_->render_pass());
    imgui_vulkan_started_ = true;
    context_->submit_and_wait([](VkCommandBuffer commands) { ImGui_ImplVulkan_CreateFontsTexture(commands); });
    ImGui_ImplVulkan_DestroyFontUploadObjects();
  }

  // A frame's geometry is taken when the frame is prepared. With two frames in flight it is
  // prepared while the previous one renders, so what it shows is a frame older than it could be;
  // on a GPU that buys throughput, on a CPU device (where "the GPU" is these same cores) it only
  // adds latency (measured on lavapipe with buddha-206k). HDEFORM_FRAMES_IN_FLIGHT overrides.
  uint32_t frames_in_flight() const {
    if (const char* value = std::getenv("HDEFORM_FRAMES_IN_FLIGHT")) return std::clamp(std::atoi(value), 1, 3);
    return context_->is_cpu_device() ? 1 : engine::kFramesInFlight;
  }

  void set_mode(Mode mode) {
    if (mode == mode_) return;
    mode_ = mode;
    glfwSetWindowTitle(window_, mode_ == Mode::Transfer ? "hdeform — transfer" : ("hdeform — " + mesh_name_).c_str());
  }

  void shutdown() {
    benchmark_.reset();  // its thread wakes the window system: stopped before that goes
    transfer_.reset();
    if (context_) vkDeviceWaitIdle(context_->device());
    document_.reset();  // stops its threads before the publisher goes
    load_.abandon();
    publisher_.reset();
    if (imgui_vulkan_started_) ImGui_ImplVulkan_Shutdown();
    if (imgui_started_) {
      ImGui_ImplGlfw_Shutdown();
      ImGui::DestroyContext();
    }
    if (imgui_pool_ != VK_NULL_HANDLE) vkDestroyDescriptorPool(context_->device(), imgui_pool_, nullptr);
    imgui_vulkan_started_ = imgui_started_ = false;
    imgui_pool_ = VK_NULL_HANDLE;
    renderer_.reset();
    exchange_.reset();
    slots_.reset();
    target_.reset();
    if (context_ && context_->validation_message_count() > 0) {
      std::cerr << "hdeform: " << context_->validation_message_count() << " Vulkan validation message(s)\n";
    }
    if (context_ && context_->validation_enabled()) {
      print_json_line({{"event", "exit"}, {"validation_messages", context_->validation_message_count()}});
    }
    context_.reset();
    if (window_ != nullptr) glfwDestroyWindow(window_);
    window_ = nullptr;
    if (glfw_started_) glfwTerminate();
    glfw_started_ = false;
  }

  // ---- documents ------------------------------------------------------------------------------

  void start_from_options() {
    if (!options_.transfer.source_rest.empty() || !options_.transfer.target.empty()) {
      set_mode(Mode::Transfer);
      transfer_->open(options_.transfer);
    }
    recovery_ = std::make_unique<RecoveryWriter>(options_.recovery_file.empty() ? default_recovery_path() : options_.recovery_file,
                                                 [](const Session& session) { print_json_line({{"event", "recovery"}, {"digest", session_digest(session)}}); });
    if (std::filesystem::exists(recovery_->path()) || std::filesystem::exists(transfer_recovery_path())) {
      if (options_.restore == "ask") return offer_restore();
      if (options_.restore == "yes") {
        restore_transfer_mode();
        if (std::filesystem::exists(recovery_->path())) return restore_recovery();
        return start_requested_document();
      }
      remove_recovery_files();
    }
    start_requested_document();
  }

  // Transfer mode's recovery file, beside the session's.
  std::filesystem::path transfer_recovery_path() const {
    const auto& path = recovery_->path();
    return path.parent_path() / (path.stem().string() + "-transfer.json");
  }

  void remove_recovery_files() {
    std::error_code ignored;
    std::filesystem::remove(recovery_->path(), ignored);
    std::filesystem::remove(transfer_recovery_path(), ignored);
  }

  void restore_transfer_mode() {
    if (!std::filesystem::exists(transfer_recovery_path())) return;
    try {
      transfer_->restore(read_transfer_state(transfer_recovery_path()));
      set_mode(Mode::Transfer);
    } catch (const std::exception& error) {
      error_message_ = std::string("Transfer mode was not restored: ") + error.what();
    }
  }

  // Transfer mode's state goes to its recovery file whenever it changes (small: written here).
  void write_transfer_recovery() {
    // Not while the question is open or a restore is loading: the file holds what is offered.
    if (!recovery_ || restore_offer_ || transfer_->restoring() || transfer_->state_version() == transfer_recovery_version_) return;
    transfer_recovery_version_ = transfer_->state_version();
    const auto state = transfer_->state();
    if (!state) return;
    try {
      std::filesystem::create_directories(transfer_recovery_path().parent_path());
      write_transfer_state(transfer_recovery_path(), *state);
      print_json_line({{"event", "transfer recovery"}, {"markers", state->markers.size()}});
    } catch (const std::exception& error) {
      std::cerr << "hdeform: warning: could not write the transfer recovery file: " << error.what() << '\n';
    }
  }

  void offer_restore() {
    const std::string requested = !options_.session.empty() ? options_.session : options_.mesh;
    try {
      restore_offer_ = make_restore_offer(recovery_->path(), transfer_recovery_path(), requested);
      print_json_line({{"event", "restore prompt"},
                       {"recovery", restore_offer_->recovery.string()},
                       {"mesh", restore_offer_->mesh},
                       {"holds", restore_offer_->holds},
                       {"transfer", restore_offer_->transfer},
                       {"requested", restore_offer_->requested}});
    } catch (const std::exception& error) {
      // Nothing to offer, but nothing thrown away either.
      const std::string reason = error.what();
      std::string kept;
      for (const auto& path : {recovery_->path(), transfer_recovery_path()}) {
        if (!std::filesystem::exists(path)) continue;
        try {
          kept += (kept.empty() ? "" : " and ") + set_recovery_aside(path).string();
        } catch (const std::exception& move_error) {
          kept += (kept.empty() ? "" : " and ") + path.string() + " (it could not be moved: " + move_error.what() + ")";
        }
      }
      error_message_ = "The recovery file could not be read: " + reason + ". It is kept as " + kept + ".";
      print_json_line({{"event", "error"}, {"message", error_message_}});
      start_requested_document();
    }
  }

  void answer_restore(RestoreChoice choice) {
    const RestoreOffer offer = *restore_offer_;
    restore_offer_.reset();
    if (choice == RestoreChoice::Restore) {
      if (offer.conflicts()) after_open_note_ = offer.requested + " was not opened (Ctrl+O opens it).";
      restore_transfer_mode();
      if (!offer.recovery.empty()) restore_recovery();
      else start_requested_document();
      return;
    }
    if (choice == RestoreChoice::OpenRequested) {
      for (const auto& path : {offer.recovery, offer.transfer_recovery}) {
        if (path.empty()) continue;
        try {
          const auto kept = set_recovery_aside(path);
          after_open_note_ += std::string(after_open_note_.empty() ? "" : " ") + "The recovered " +
                              (path == offer.recovery ? "session" : "transfer state") + " is kept as " + kept.string() + ".";
          print_json_line({{"event", "recovery kept"}, {"path", kept.string()}});
        } catch (const std::exception& error) {
          error_message_ = std::string("The recovery file could not be set aside: ") + error.what();
        }
      }
    } else {
      remove_recovery_files();
    }
    start_requested_document();
  }

  void restore_recovery() {
    const auto path = recovery_->path();
    start_load("the recovered session", [path] {
      SessionSource source;
      Session session = read_session(path, &source);
      return std::pair{session, load_session_mesh(session, &source)};
    });
  }

  // The document the command line asked for.
  void start_requested_document() {
    const EditorOptions options = options_;
    last_open_request_ = !options.session.empty() ? options.session : options.mesh;
    const std::string what = !options.session.empty() ? options.session : options.mesh.empty() ? std::string("the cactus") : options.mesh;
    start_load(what, [options] {
      if (!options.session.empty()) {
        SessionSource source;
        Session session = read_session(options.session, &source);
        return std::pair{session, load_session_mesh(session, &source)};
      }
      Session session;
      session.current.refine = options.refine;
      session.mesh = options.mesh.empty() ? "shape:cactus" : options.mesh;
      if (!names_builtin_shape(session.mesh)) session.mesh = std::filesystem::absolute(session.mesh).lexically_normal().string();
      LoadedMesh loaded = load_mesh(MeshSource::from_name(session.mesh));
      Mesh mesh = std::move(loaded.mesh);
      if (loaded.demo_constraints && options.handles.empty()) {
        // A built-in shape starts with its demo's source and sink painted, ready to drag.
        session.current.fixed = loaded.demo_constraints->fixed;
        session.current.handles.push_back({loaded.demo_constraints->handles[0], pose_for(loaded.demo_constraints->handles[0], mesh, {})});
      }
      if (!options.fixed.empty()) session.current.fixed = read_vertex_list(options.fixed, mesh.vertex_count(), "the fixed vertices are the sinks");
      if (!options.roi.empty()) {
        session.current.region_of_interest = read_vertex_list(options.roi, mesh.vertex_count(), "an empty region of interest leaves nothing to deform");
      }
      for (std::size_t h = 0; h < options.handles.size(); ++h) {
        auto vertices = read_vertex_list(options.handles[h], mesh.vertex_count(), "a handle needs at least one vertex");
        std::optional<HandleTransform> target;
        if (h < options.transforms.size()) target = read_handle_transform(options.transforms[h]);
        session.current.handles.push_back({vertices, pose_for(vertices, mesh, target)});
      }
      if (!options.handles.empty()) refuse_contradictions(session.current.constraints(), options.fixed, options.handles);
      return std::pair{session, mesh};
    });
  }

  // A pose about the handle's centroid; with `target`, the pose that reaches it (rotation and
  // uniform scale; a 3×4 matrix's stretch is dropped, as the gizmo has none).
  static HandleTransform pose_for(const std::vector<int>& vertices, const Mesh& mesh, const std::optional<HandleTransform>& target) {
    Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
    for (const int v : vertices) pivot += mesh.positions.row(v).transpose();
    pivot /= static_cast<double>(vertices.size());
    if (!target) return HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), pivot, 0.0);
    const Eigen::Vector3d shift = target->apply(pivot) - pivot;
    return HandleTransform::about_pivot(target->axis, pivot, target->angle, target->scale, shift);
  }

  template <class Load>
  void start_load(const std::string& what, Load load) {
    load_.start("Loading " + what, [load] {
      auto [session, mesh] = load();
      Loaded loaded;
      loaded.session = std::move(session);
      loaded.mesh = std::move(mesh);
      // Replaying applied stages and the checks run here, off the frame loop; the publisher is
      // attached when the document is installed.
      loaded.document = std::make_unique<Document>(loaded.session, loaded.mesh, DeformerOptions{}, Document::Publish{});
      return loaded;
    }, [] { glfwPostEmptyEvent(); });
  }

  struct Loaded {
    Session session;
    Mesh mesh;
    std::unique_ptr<Document> document;
  };

  void finish_load() {
    if (!load_.done()) return;
    auto outcome = load_.take();
    if (!outcome.error.empty()) {
      const std::string& failure = outcome.error;
      error_message_ = failure;
      open_failure_ = failure;
      if (!after_open_note_.empty()) status_ = after_open_note_;
      after_open_note_.clear();
      print_json_line({{"event", "error"}, {"message", failure}});
      if (!document_ && (options_.benchmark_drag_seconds > 0.0)) {
        std::cerr << "hdeform: error: " << failure << '\n';
        exit_code_ = 1;
        quit_ = true;
      }
      return;
    }
    install(std::move(*outcome.result));
  }

  void install(Loaded loaded_document) {
    Loaded* loaded = &loaded_document;
    vkDeviceWaitIdle(context_->device());
    document_.reset();  // its pipeline stops before its publisher goes
    publisher_.reset();
    const Mesh& rest = loaded->document->rest();
    exchange_ = std::make_unique<engine::GeometryExchange>(static_cast<std::size_t>(rest.vertex_count()));
    publisher_ = std::make_unique<engine::GeometryPublisher>(*exchange_, rest.triangles);
    loaded->document->set_publish([this](const Eigen::MatrixXd& positions, std::uint64_t request) {
      publisher_->publish(positions, request);
      glfwPostEmptyEvent();
    });
    document_ = std::move(loaded->document);
    publisher_->publish(document_->rest().positions, 0);
    mesh_name_ = loaded->session.mesh;
    const auto bounds = engine::Bounds::of(document_->rest().positions);
    renderer_->set_mesh(document_->rest().triangles, *exchange_, bounds, up_axis());
    picker_.reset();
    adjust_camera(true);
    brush_radius_ = 0.03f * bounds.radius() * 2.0f;
    view_dirty_ = true;
    shown_tag_ = 0;
    if (options_.output.empty() && !names_builtin_shape(mesh_name_)) {
      std::filesystem::path output(mesh_name_);
      output_path_ = (output.parent_path() / (output.stem().string() + "-edited.obj")).string();
    } else if (options_.output.empty()) {
      output_path_ = (std::filesystem::current_path() / (MeshSource::from_name(mesh_name_).shape_name + "-edited.obj")).string();
    } else {
      output_path_ = options_.output;
    }
    glfwSetWindowTitle(window_, ("hdeform — " + mesh_name_).c_str());
    status_ = "Opened " + mesh_name_;
    if (!after_open_note_.empty()) status_ += ". " + after_open_note_;
    after_open_note_.clear();
    error_message_.clear();
    print_json_line({{"event", "opened"},
                     {"mesh", mesh_name_},
                     {"vertices", rest.vertex_count()},
                     {"triangles", rest.triangle_count()},
                     {"session_digest", session_digest(document_->session())}});
    document_->request_update();
    post_recovery();
  }

  engine::UpAxis up_axis() const { return options_.up == "y" ? engine::UpAxis::Y : engine::UpAxis::Z; }

  void adjust_camera(bool reset_angles) {
    if (!document_) return;
    const auto extent = target_->extent();
    const float aspect = extent.height > 0 ? static_cast<float>(extent.width) / static_cast<float>(extent.height) : 1.0f;
    const auto bounds = engine::Bounds::of(document_->rest().positions);
    if (reset_angles) camera_ = engine::Camera::three_quarter_front(bounds, up_axis(), aspect);
    else camera_.fit(bounds, aspect);
  }

  void open_path(const std::string& path) {
    last_open_request_ = path;
    if (path.ends_with(".json")) {
      start_load(path, [path] {
        SessionSource source;
        Session session = read_session(path, &source);
        return std::pair{session, load_session_mesh(session, &source)};
      });
      return;
    }
    start_load(path, [path, refine = options_.refine] {
      Session session;
      session.current.refine = refine;
      session.mesh = names_builtin_shape(path) ? path : std::filesystem::absolute(path).lexically_normal().string();
      return std::pair{session, load_session_mesh(session)};
    });
  }

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
  void wait_for_device() {
    if (!document_) return;
    while (!quit_ && !slots_->next_ready(std::chrono::milliseconds(1))) take_input_while_waiting();
    if (!latch_solves_ || unposted_events_.empty()) return;
    const std::uint64_t request = post_pending_solve();
    const double latch_ms = std::min(2.0 * statistics_.recent_update_ms(10.0) + 2.0, kMaxLatchMs);
    const auto latch_end = Clock::now() + std::chrono::microseconds(static_cast<long>(latch_ms * 1000.0));
    while (!quit_ && request > 0 && document_->last_published_request() < request && Clock::now() < latch_end) {
      glfwWaitEventsTimeout(0.001);
      take_input_while_waiting();
    }
  }

  void take_input_while_waiting() {
    glfwPollEvents();
    if (dragging_ && !is_paint_tool(tools_.tool)) {
      double x = 0.0, y = 0.0;
      glfwGetCursorPos(window_, &x, &y);
      continue_handle_drag(ImVec2(static_cast<float>(x), static_cast<float>(y)), last_input_);
    }
    if (benchmark_) take_benchmark_input();
  }

  // A pose changed by input: posted now ("free"), or when the device is next free ("latch").
  void note_pose_input(Clock::time_point event_time) { note_pose_input(std::span(&event_time, 1)); }
  void note_pose_input(std::span<const Clock::time_point> events) {
    for (std::size_t k = 0; k < events.size(); ++k) trace::instant("pose input", "input");
    unposted_events_.insert(unposted_events_.end(), events.begin(), events.end());
    if (!latch_solves_) post_pending_solve();
  }

  // Posts the solve of the current poses for the inputs not posted yet; returns its request (0: none).
  std::uint64_t post_pending_solve() {
    if (unposted_events_.empty()) return 0;
    const std::uint64_t request = post_request(unposted_events_);
    unposted_events_.clear();
    return request;
  }


  void step() {
    const std::vector<InputEvent> events = input_.take_frame();
    frame_keys_.clear();
    for (const InputEvent& event : events) {
      if (event.kind == InputEvent::Kind::Key && event.action == GLFW_PRESS) frame_keys_.push_back({event.code, event.mods});
    }
    finish_load();
    if (!dropped_paths_.empty()) {
      if (mode_ == Mode::Transfer) transfer_->drop(dropped_paths_, ImGui::GetIO().MousePos);
      else open_path(dropped_paths_.front());
      dropped_paths_.clear();
    }
    transfer_->poll();
    write_transfer_recovery();
    if (document_) {
      const auto before = document_->solver_state();
      document_->poll();
      // On a CPU device (latch pacing) iterations would take the cores the frame needs: they
      // wait until the input rests (buddha-206k on lavapipe: 17.7 fps and 99 ms input to screen
      // with iterations between the drag's updates, against 29.7 fps and 52 ms without).
      document_->set_refinement_delay(std::chrono::milliseconds(latch_solves_ ? kRefineAfterRestMs : 0));
      if (document_->solver_state() != before) {
        view_dirty_ = true;
        announce_solver_state();
      }
      if (document_->solver_state() == Document::SolverState::Building && build_started_ == Clock::time_point{}) build_started_ = Clock::now();
      if (document_->solver_state() != Document::SolverState::Building) build_started_ = {};
    }
    if (benchmark_ || (options_.benchmark_drag_seconds > 0.0 && !benchmark_done_)) benchmark_step();

    ImGui_ImplVulkan_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    imgui_input_.apply(events);
    ImGui::NewFrame();
    draw_panel();
    take_profile();
    profiler_.draw(show_profiler_);
    draw_dialogs();
    handle_keys();
    if (mode_ == Mode::Transfer) {
      transfer_->handle_mouse();
      if (!view_only_screenshot()) transfer_->draw_overlays();
    } else {
      handle_mouse();
      draw_overlays();
    }
    ImGui::Render();
    sync_view();
    render(ImGui::GetDrawData());
    if (recovery_dirty_ && seconds_since(last_recovery_) > kRecoveryInterval) post_recovery();
  }

  // On stdout, for scripts and tests that drive the editor.
  void announce_solver_state() {
    switch (document_->solver_state()) {
      case Document::SolverState::Ready:
        print_json_line({{"event", "solver"}, {"state", "ready"}, {"factor_ms", document_->setup_timings()->factor_ms}});
        break;
      case Document::SolverState::Failed:
        print_json_line({{"event", "solver"}, {"state", "failed"}, {"message", document_->solver_message()}});
        break;
      case Document::SolverState::NoHandle: print_json_line({{"event", "solver"}, {"state", "no handle"}}); break;
      case Document::SolverState::Building: break;
    }
  }

  void sync_view() {
    if (!document_ || !view_dirty_) return;
    view_dirty_ = false;
    const auto n = static_cast<int>(document_->vertex_count());
    std::vector<uint32_t> classes(static_cast<std::size_t>(n), HD_CLASS_FREE);
    for (int v = 0; v < n; ++v) {
      const int label = document_->label(v);
      if (label >= 0) classes[static_cast<std::size_t>(v)] = engine::handle_class(static_cast<std::size_t>(label));
      else if (label == Document::kFixed) classes[static_cast<std::size_t>(v)] = engine::fixed_class();
      else if (document_->has_region_of_interest() && !document_->in_region_of_interest(v)) classes[static_cast<std::size_t>(v)] = engine::outside_class();
    }
    renderer_->set_classes(classes);
    if (const Eigen::VectorXd* field = document_->field()) {
      const Eigen::VectorXf values = field->cast<float>();
      renderer_->set_field({values.data(), static_cast<std::size_t>(values.size())});
    } else {
      renderer_->set_field({});
    }
  }

  void render(ImDrawData* draw_data) {
    if (document_ && document_->last_update_ms() != last_update_seen_) {
      last_update_seen_ = document_->last_update_ms();
      statistics_.note_update(last_update_seen_);
    }
    engine::FrameSlots::Slot& slot = slots_->begin();
    const auto now = Clock::now();
    note_finished_frames();
    uint32_t image = 0;
    if (!target_->acquire(slot.image_available, image)) return;  // minimised or rebuilt: draw next time
    const VkExtent2D extent = target_->extent();
    if (mode_ == Mode::Transfer) {
      transfer_->prepare(slot.index, extent, kPanelWidth * ImGui::GetIO().DisplayFramebufferScale.x);
    } else {
      renderer_->prepare(slot.index, camera_, settings_, extent);
      shown_tag_ = renderer_->drawn_geometry_tag();
    }
    target_->begin(slot.commands, image);
    if (mode_ == Mode::Transfer) transfer_->record(slot.commands, slot.index);
    else renderer_->record(slot.commands, slot.index, extent);
    const bool screenshot = screenshot_requested_;
    if (!view_only_screenshot()) ImGui_ImplVulkan_RenderDrawData(draw_data, slot.commands);
    target_->end(slot.commands, image, screenshot);
    const std::uint64_t frame = slots_->submit(slot, slot.image_available, target_->render_finished(image));
    last_submitted_frame_ = frame;
    statistics_.note_submitted(frame, shown_tag_, waited_idle_, now);
    waited_idle_ = false;
    target_->present(image);
    if (screenshot) {
      slots_->wait_all();
      write_screenshot(target_->read_last_image());
      screenshot_requested_ = false;
    }
  }

  // The profiler's bars: the document's updates and iterations, and each frame's processor time
  // joined with the device's time for it once that is known.
  void take_profile() {
    if (document_) {
      for (const auto& timings : document_->take_update_timings()) profiler_.add_update(timings);
      for (const auto& timings : document_->take_refinement_timings()) profiler_.add_refinement(timings);
    }
    if (!slots_->has_device_times()) {
      for (const auto& [frame, cpu_ms] : frame_work_) profiler_.add_frame(cpu_ms, 0.0);
      frame_work_.clear();
      return;
    }
    for (const auto& device : slots_->take_device_times()) {
      const auto it = std::find_if(frame_work_.begin(), frame_work_.end(), [&](const auto& work) { return work.first == device.frame; });
      if (it == frame_work_.end()) continue;
      profiler_.add_frame(it->second, device.milliseconds);
      frame_work_.erase(frame_work_.begin(), it + 1);
    }
    while (frame_work_.size() > 16) frame_work_.pop_front();
  }

  void note_frame_work(double cpu_ms) {
    if (last_submitted_frame_ != 0) frame_work_.emplace_back(last_submitted_frame_, cpu_ms);
    last_submitted_frame_ = 0;
  }

  // Frames the device finished (timed by a thread that waits on a timeline semaphore): the
  // frame cadence while the loop runs without idling, and for the first frame that shows a
  // request's result, the latency from the input event that caused it.
  void note_finished_frames() {
    for (const auto& completion : slots_->take_completions()) statistics_.note_finished(completion.frame, completion.time);
  }

  bool view_only_screenshot() const { return screenshot_requested_ && !screenshot_with_panel_; }

  void write_screenshot(const engine::Pixels& pixels) {
    const auto path = std::filesystem::path(options_.screenshot_dir) / ("screenshot-" + std::to_string(++screenshots_) + ".png");
    try {
      engine::write_png(path, pixels);
      status_ = "Screenshot " + path.string();
      print_json_line({{"event", "screenshot"}, {"path", path.string()}});
    } catch (const std::exception& error) {
      error_message_ = error.what();
    }
  }

  // ---- the panel ----------------------------------------------------------------------------------

  // The panel: its controls scroll, and below them the status, the error and the live figures
  // stay in view at any window height.
  void draw_panel() {
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(kPanelWidth, ImGui::GetIO().DisplaySize.y));
    ImGui::Begin("hdeform", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
    const bool editing = mode_ == Mode::Edit;
    const float wrap = ImGui::GetContentRegionAvail().x;
    const auto wrapped_height = [wrap](const std::string& text) { return text.empty() ? 0.0f : ImGui::CalcTextSize(text.c_str(), nullptr, false, wrap).y; };
    const ImGuiStyle& style = ImGui::GetStyle();
    const int figure_lines = editing && document_ ? 5 : 0;
    const float footer = editing ? style.ItemSpacing.y * 4 + style.WindowPadding.y + wrapped_height(status_) + wrapped_height(error_message_) +
                                       static_cast<float>(figure_lines) * ImGui::GetTextLineHeightWithSpacing()
                                 : 0.0f;
    ImGui::BeginChild("controls", ImVec2(0, -footer));
    draw_controls();
    ImGui::EndChild();
    if (editing) draw_footer();
    ImGui::End();
  }

  void draw_footer() {
    ImGui::Separator();
    if (document_) {
      if (const DeformerTimings* timings = document_->setup_timings()) ImGui::Text("Factorization: %.1f ms", timings->factor_ms);
      else ImGui::TextDisabled("Factorization: -");
      ImGui::Text("Last update: %.2f ms", document_->last_update_ms());
      ImGui::Text("Frames: %zu per second", statistics_.frames_per_second(Clock::now()));
      ImGui::Text("Frame: %s", percentile_text(statistics_.frame_intervals()).c_str());
      ImGui::Text("Input to screen: %s", percentile_text(statistics_.latencies()).c_str());
    }
    ImGui::TextWrapped("%s", status_.c_str());
    if (!error_message_.empty()) {
      ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1, 0.45f, 0.45f, 1));
      ImGui::TextWrapped("%s", error_message_.c_str());
      ImGui::PopStyleColor();
    }
  }

  void draw_controls() {
    int mode = mode_ == Mode::Transfer ? 1 : 0;
    ImGui::RadioButton("Edit", &mode, 0);
    ImGui::SameLine();
    ImGui::RadioButton("Transfer (Ctrl+T)", &mode, 1);
    set_mode(mode == 1 ? Mode::Transfer : Mode::Edit);
    ImGui::Separator();
    if (mode_ == Mode::Transfer) {
      transfer_->draw_panel(pressed(GLFW_KEY_ESCAPE));
      return;
    }
    ImGui::TextWrapped("%s", !mesh_name_.empty() ? mesh_name_.c_str()
                                        : load_.running() ? "(loading)"
                                        : restore_offer_ ? "Restore the last session? (the question in the middle)"
                                                         : "No mesh open: Open... or drop an OBJ file here");
    if (document_) ImGui::Text("%ld vertices, %ld triangles", static_cast<long>(document_->vertex_count()), static_cast<long>(document_->rest().triangle_count()));
    if (ImGui::Button("Open...")) request_open();
    ImGui::SameLine();
    if (ImGui::Button("Save")) save(output_path_);
    ImGui::SameLine();
    if (ImGui::Button("Save as...")) request_save_as();
    ImGui::SameLine();
    if (ImGui::Button("Help")) show_help_ = !show_help_;
    if (!document_) return;

    ImGui::Separator();
    ImGui::TextDisabled("Tool");
    for (const Tool tool : {Tool::PaintRoi, Tool::PaintFixed, Tool::PaintHandle, Tool::Grab, Tool::Rotate, Tool::Scale, Tool::Twist}) {
      if (ImGui::RadioButton(tool_name(tool), tools_.tool == tool)) tools_.tool = tool;
    }
    const float column = ImGui::GetContentRegionAvail().x * 0.5f;  // two columns: no label past the edge
    ImGui::Checkbox("Erase (E)", &tools_.erase);
    ImGui::SameLine(column);
    ImGui::Checkbox("Lasso (L)", &tools_.lasso);
    ImGui::Checkbox("Paint through, front and back (Alt+Z)", &tools_.paint_through);
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("The brush and the lasso take every vertex under them, also those facing away:\na ring painted from one side is the whole ring.");
    ImGui::SliderFloat("Brush", &brush_radius_, 0.001f * scene_size(), 0.2f * scene_size(), "%.4f");
    if (ImGui::Button("Invert")) layer_action("invert", [this](Layer layer) { document_->invert(layer); });
    ImGui::SameLine();
    if (ImGui::Button("Grow")) layer_action("grow", [this](Layer layer) { document_->grow(layer); });
    ImGui::SameLine();
    if (ImGui::Button("Shrink")) layer_action("shrink", [this](Layer layer) { document_->shrink(layer); });
    ImGui::SameLine();
    if (ImGui::Button("Clear")) layer_action("clear", [this](Layer layer) { document_->clear(layer); });
    if (ImGui::Button("Connected (C)")) tools_.connected_armed = true;
    if (document_->has_region_of_interest()) ImGui::Text("Region of interest: %zu vertices", document_->region_of_interest_size());
    else ImGui::Text("Region of interest: the whole mesh");
    ImGui::Text("Fixed: %zu vertices", document_->fixed_count());

    ImGui::Separator();
    ImGui::TextDisabled("Handles");
    for (int h = 0; h < static_cast<int>(document_->handle_count()); ++h) {
      const auto& color = engine::class_colors()[static_cast<std::size_t>(HD_FIRST_HANDLE_COLOR + h % HD_HANDLE_COLORS)];
      ImGui::ColorButton(("##handle" + std::to_string(h)).c_str(), ImVec4(color.x(), color.y(), color.z(), 1.0f), ImGuiColorEditFlags_NoTooltip,
                         ImVec2(14, 14));
      ImGui::SameLine();
      const std::string label = "Handle " + std::to_string(h + 1) + " (" + std::to_string(document_->handle_size(h)) + " vertices)";
      if (ImGui::Selectable(label.c_str(), document_->active_handle() == h)) document_->set_active_handle(h);
    }
    if (ImGui::Button("New handle (N)")) {
      document_->add_handle();
      tools_.tool = Tool::PaintHandle;
    }
    ImGui::SameLine();
    if (ImGui::Button("Remove") && document_->handle_count() > 0) finish_action("remove handle " + std::to_string(document_->active_handle() + 1), [this] { document_->remove_handle(document_->active_handle()); });
    draw_pose_editor();

    ImGui::Separator();
    ImGui::TextDisabled("Edit");
    if (ImGui::Button("Undo")) undo();
    ImGui::SameLine();
    if (ImGui::Button("Redo")) redo();
    ImGui::SameLine();
    if (ImGui::Button("Reset (0)")) finish_action("reset the handles", [this] { document_->reset_poses(); });
    ImGui::SameLine();
    if (ImGui::Button("Apply (A)")) apply();

    ImGui::Separator();
    ImGui::TextDisabled("View");
    // Two columns, so that no label runs past the panel's edge.
    if (ImGui::Checkbox("Field (H)", &settings_.show_field)) view_dirty_ = true;
    ImGui::SameLine(column);
    ImGui::Checkbox("Classes (K)", &settings_.show_classes);
    ImGui::Checkbox("Wireframe (W)", &settings_.wireframe);
    ImGui::SameLine(column);
    ImGui::Checkbox("Flat", &settings_.flat_shading);
    ImGui::Checkbox("Ground", &settings_.ground);
    ImGui::SameLine(column);
    ImGui::Checkbox("Legend", &settings_.legend);
    ImGui::SliderFloat("Isolines", &settings_.isoline_step, 0.0f, 0.5f, "%.3f");
    if (ImGui::Button("Fit (F)")) adjust_camera(false);

    ImGui::Separator();
    ImGui::TextDisabled("Solver");
    const char* backends[] = {"eigen", "cholmod"};
    int backend = document_->options().backend == SolverBackend::Eigen ? 0 : 1;
    if (ImGui::Combo("Backend", &backend, backends, backend_available(SolverBackend::Cholmod) ? 2 : 1)) {
      DeformerOptions solver_options = document_->options();
      solver_options.backend = backend == 0 ? SolverBackend::Eigen : SolverBackend::Cholmod;
      document_->set_options(solver_options);
    }
    switch (document_->solver_state()) {
      case Document::SolverState::NoHandle: ImGui::TextWrapped("Paint a handle (3) to deform."); break;
      case Document::SolverState::Building: ImGui::TextWrapped("%s...", document_->solver_message().c_str()); break;
      case Document::SolverState::Failed: ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", document_->solver_message().c_str()); break;
      case Document::SolverState::Ready: break;
    }
    bool refine = document_->refine();
    if (ImGui::Checkbox("Refine (as rigid as possible)", &refine)) {
      document_->set_refine(refine);
      document_->commit(refine ? "refinement on" : "refinement off");
      if (!refine) document_->request_update();  // back to the paper's result on screen
      status_ = refine ? "Refinement on: after each update, iterations until the shape settles" : "Refinement off: the paper's method alone";
    }
    if (ImGui::IsItemHovered()) {
      ImGui::SetTooltip("Local/global as-rigid-as-possible iterations after the paper's update: a drag bends\n"
                        "instead of shearing. Each frame shows the newest update first; iterations follow while\n"
                        "the input rests, each shown as it lands, until the energy settles.");
    }
    if (refine) {
      const auto view = document_->refinement();
      const auto& status = view.status;
      if (status.iterations == 0) {
        ImGui::TextDisabled("Refinement: waiting for the update");
      } else {
        ImGui::Text("Refinement: %d iterations%s", status.iterations, status.converged ? ", settled" : "...");
        ImGui::Text("Energy %.4g (paper's %.4g, %.1f ms each)", status.energy, status.unrefined_energy, view.iteration_ms);
      }
    }
    ImGui::Checkbox("Profiler (P)", &show_profiler_);
    ImGui::Checkbox("Solve before each frame", &latch_solves_);
    if (ImGui::IsItemHovered()) {
      ImGui::SetTooltip("On: a frame waits up to %.0f ms for the solve of the newest input (best on a CPU device).\n"
                        "Off: frames never wait; each shows the newest finished solve.", kMaxLatchMs);
    }
  }

  void draw_pose_editor() {
    const int h = document_->active_handle();
    if (document_->handle_count() == 0 || document_->handle_size(h) == 0) return;
    const HandleTransform& pose = document_->pose(h);
    PoseFields fields{pose.shift, pose.axis, pose.angle * 180.0 / std::numbers::pi, pose.scale};
    announce_pose_fields();
    const PoseFieldsEdit edit = pose_fields(fields, 0.002f * scene_size());
    if (edit.changed) {
      document_->set_pose(h, fields.axis, fields.degrees * std::numbers::pi / 180.0, fields.scale, fields.shift);
      note_pose_input(Clock::now());
      recovery_dirty_ = true;
    }
    if (edit.finished) commit_action("the pose of handle " + std::to_string(h + 1) + " typed");
  }

  // Where the pose fields are (Move, Axis, Angle, Scale: one row each), on stdout whenever that
  // changes, for scripts that type into them.
  void announce_pose_fields() {
    const ImVec2 at = ImGui::GetCursorScreenPos();
    const std::array<float, 4> layout{at.x, at.y, ImGui::CalcItemWidth(), ImGui::GetFrameHeightWithSpacing()};
    if (layout == announced_pose_fields_) return;
    announced_pose_fields_ = layout;
    print_json_line({{"event", "pose fields"}, {"x", layout[0]}, {"y", layout[1]}, {"width", layout[2]}, {"row", layout[3]}});
  }

  void draw_dialogs() {
    if (show_help_) {
      ImGui::SetNextWindowPos(ImVec2(kPanelWidth + 20, 20), ImGuiCond_Appearing);
      ImGui::Begin("Shortcuts (F1)", &show_help_, ImGuiWindowFlags_AlwaysAutoResize);
      if (ImGui::BeginTable("shortcuts", 2, ImGuiTableFlags_SizingFixedFit | ImGuiTableFlags_RowBg)) {
        for (const auto& [keys, action] : kShortcuts) {
          ImGui::TableNextRow();
          ImGui::TableNextColumn();
          ImGui::TextUnformatted(keys);
          ImGui::TableNextColumn();
          ImGui::TextUnformatted(action);
        }
        ImGui::EndTable();
      }
      ImGui::End();
    }
    const auto transfer_work = transfer_->work();
    const bool busy = load_.running() || (document_ && document_->solver_state() == Document::SolverState::Building) || transfer_work;
    const double busy_for = transfer_work ? transfer_work->second
                            : load_.running() ? load_.seconds()
                                          : (build_started_ != Clock::time_point{} ? seconds_since(build_started_) : 0.0);
    if (busy && busy_for > kProgressDelay) {
      const ImVec2 size = ImGui::GetIO().DisplaySize;
      ImGui::SetNextWindowPos(ImVec2(size.x * 0.5f + kPanelWidth * 0.5f, size.y * 0.5f), ImGuiCond_Always, ImVec2(0.5f, 0.5f));
      ImGui::Begin("Working", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoInputs);
      const char* spinner = "|/-\\";
      const std::string what = transfer_work ? transfer_work->first
                               : load_.running() ? load_.what()
                                             : document_->solver_message();
      ImGui::Text("%c %s  (%.1f s)", spinner[static_cast<int>(busy_for * 8) % 4], what.c_str(), busy_for);
      ImGui::End();
    }
    if (restore_offer_) {
      const RestoreChoice choice = restore_prompt(*restore_offer_, pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER), pressed(GLFW_KEY_ESCAPE));
      if (choice != RestoreChoice::Undecided) answer_restore(choice);
    }
    draw_open_failure();
    if (const auto path = path_prompt("Open", open_dialog_, path_buffer_, pressed(GLFW_KEY_ESCAPE))) open_path(*path);
    if (const auto path = path_prompt("Save as", save_dialog_, path_buffer_, pressed(GLFW_KEY_ESCAPE)); path && save(*path)) output_path_ = *path;
    if (quit_dialog_) ImGui::OpenPopup("Quit");
    if (ImGui::BeginPopupModal("Quit", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
      ImGui::Text("Quit without saving the changes?");
      if (ImGui::Button("Quit (Enter)") || pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER)) quit_ = true;
      ImGui::SameLine();
      if (ImGui::Button("Cancel (Esc)") || pressed(GLFW_KEY_ESCAPE)) {
        quit_dialog_ = false;
        ImGui::CloseCurrentPopup();
      }
      ImGui::EndPopup();
    }
  }

  // The Open box starts from something that exists: the open mesh, else the folder of the file
  // last asked for, else the working folder.
  void request_open() {
    std::vector<std::filesystem::path> candidates;
    if (!mesh_name_.empty() && !names_builtin_shape(mesh_name_)) candidates.emplace_back(mesh_name_);
    if (!last_open_request_.empty() && !names_builtin_shape(last_open_request_)) candidates.push_back(std::filesystem::absolute(last_open_request_).parent_path());
    candidates.push_back(std::filesystem::current_path());
    std::string start;
    for (const auto& candidate : candidates) {
      std::error_code ignored;
      if (!std::filesystem::exists(candidate, ignored)) continue;
      start = candidate.string();
      if (std::filesystem::is_directory(candidate, ignored) && !start.ends_with('/')) start += '/';
      break;
    }
    std::snprintf(path_buffer_, sizeof path_buffer_, "%s", start.c_str());
    open_dialog_ = true;
  }

  void request_save_as() {
    std::snprintf(path_buffer_, sizeof path_buffer_, "%s", output_path_.c_str());
    save_dialog_ = true;
  }

  // A file that could not be opened (from the command line, Open, a drop or a session): the
  // reason in full, in the window, with the previous document (if any) still open behind it.
  void draw_open_failure() {
    if (!open_failure_.empty() && !ImGui::IsPopupOpen("Could not open")) {
      ImGui::OpenPopup("Could not open");
      print_json_line({{"event", "dialog"}, {"title", "Could not open"}, {"message", open_failure_}});
    }
    if (!ImGui::BeginPopupModal("Could not open", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
    ImGui::PushTextWrapPos(ImGui::GetFontSize() * 36.0f);
    ImGui::TextUnformatted(open_failure_.c_str());
    ImGui::TextDisabled("%s", document_ ? ("Still open: " + mesh_name_).c_str() : "No mesh is open.");
    ImGui::PopTextWrapPos();
    const auto close = [this] {
      open_failure_.clear();
      ImGui::CloseCurrentPopup();
    };
    if (ImGui::Button("Open another... (Enter)") || pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER)) {
      close();
      request_open();
    }
    ImGui::SameLine();
    if (ImGui::Button("Copy the message")) ImGui::SetClipboardText(open_failure_.c_str());
    ImGui::SameLine();
    if (ImGui::Button("Close (Esc)") || pressed(GLFW_KEY_ESCAPE)) close();
    ImGui::EndPopup();
  }

  // ---- actions ------------------------------------------------------------------------------------

  // A finished action: one undo step named `what`, the view refreshed, the recovery file written.
  void commit_action(const std::string& what) {
    if (!document_) return;
    document_->commit(what);
    view_dirty_ = true;
    post_recovery();
  }

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
  std::string layer_name() const {
    switch (layer_of(tools_.tool)) {
      case Layer::RegionOfInterest: return "the region of interest";
      case Layer::Fixed: return "fixed";
      case Layer::Handle: return "handle " + std::to_string(document_->active_handle() + 1);
    }
    return "";
  }

  void undo() {
    if (!document_) return;
    if (document_->undo()) after_history_step("Undone: " + document_->last_history_step());
    else status_ = "Nothing to undo";
  }
  void redo() {
    if (!document_) return;
    if (document_->redo()) after_history_step("Redone: " + document_->last_history_step());
    else status_ = "Nothing to redo";
  }
  void after_history_step(const std::string& what) {
    view_dirty_ = true;
    publish_rest_if_needed();
    post_request(Clock::now());
    post_recovery();
    status_ = what;
  }

  void apply() {
    if (!document_ || document_->handle_count() == 0) return;
    try {
      document_->apply();
      commit_action("apply");
      publish_rest_if_needed();
      status_ = "Applied: the result is the new rest shape";
    } catch (const std::exception& error) {
      error_message_ = error.what();
    }
  }

  // Without a solver (no handle) nothing publishes: show the rest shape.
  void publish_rest_if_needed() {
    if (document_->solver_state() == Document::SolverState::NoHandle || document_->handle_count() == 0) publisher_->publish(document_->rest().positions, 0);
  }

  // Posts the current poses, answering the inputs that led to them (their times, for latency).
  std::uint64_t post_request(std::span<const Clock::time_point> events) {
    if (!document_) return 0;
    const std::uint64_t request = document_->request_update();
    if (request == 0) return 0;
    statistics_.note_request(request, events);
    return request;
  }
  std::uint64_t post_request(Clock::time_point event_time) { return post_request(std::span(&event_time, 1)); }

  void post_recovery() {
    if (!document_ || !recovery_) return;
    recovery_->post(document_->session());
    last_recovery_ = Clock::now();
    recovery_dirty_ = false;
  }

  bool save(const std::string& path) {
    if (!document_ || path.empty()) return false;
    try {
      const Eigen::MatrixXd result = document_->result();
      write_obj(path, Mesh{result, document_->rest().triangles});
      write_session(session_path_for(path), document_->session());
      document_->mark_saved();
      status_ = "Saved " + path + " and " + session_path_for(path);
      error_message_.clear();
      print_json_line({{"event", "saved"}, {"obj", path}, {"session", session_path_for(path)}});
      return true;
    } catch (const std::exception& error) {
      error_message_ = error.what();
      return false;
    }
  }

  // The state goes to the recovery file, synchronously, and stays there for the next start.
  void quit_on_signal(int signal) {
    if (document_ && recovery_) {
      recovery_->post(document_->session());
      recovery_->flush();
    }
    if (recovery_) {
      transfer_recovery_version_ = ~std::uint64_t{0};  // written now, whatever was written before
      write_transfer_recovery();
    }
    keep_recovery_ = recovery_ && (std::filesystem::exists(recovery_->path()) || std::filesystem::exists(transfer_recovery_path()));
    print_json_line({{"event", "signal"},
                     {"signal", signal == SIGTERM ? "SIGTERM" : signal == SIGINT ? "SIGINT" : "SIGHUP"},
                     {"recovery", keep_recovery_ ? recovery_->path().string() : ""}});
    std::cerr << "hdeform: stopped by a signal; " << (keep_recovery_ ? "the session is in " + recovery_->path().string() + ", offered at the next start" : std::string("nothing to recover"))
              << '\n';
    exit_code_ = 128 + signal;
    quit_ = true;
  }

  void request_quit() {
    if (document_ && document_->modified() && options_.benchmark_drag_seconds <= 0.0) quit_dialog_ = true;
    else quit_ = true;
  }

  float scene_size() const { return document_ ? 2.0f * engine::Bounds::of(document_->rest().positions).radius() : 1.0f; }

  // ---- input ------------------------------------------------------------------------------------------

  void handle_keys() {
    // Screenshots work over dialogs too (a picture of what went wrong).
    if (pressed(GLFW_KEY_F12) || pressed(GLFW_KEY_F12, GLFW_MOD_SHIFT)) {
      screenshot_requested_ = true;
      screenshot_with_panel_ = pressed(GLFW_KEY_F12, GLFW_MOD_SHIFT);
    }
    const ImGuiIO& io = ImGui::GetIO();
    if (io.WantCaptureKeyboard) return;
    constexpr int kCtrl = GLFW_MOD_CONTROL;
    if (pressed(GLFW_KEY_T, kCtrl)) set_mode(mode_ == Mode::Transfer ? Mode::Edit : Mode::Transfer);
    if (pressed(GLFW_KEY_Q, kCtrl)) request_quit();
    if (pressed(GLFW_KEY_F1)) show_help_ = !show_help_;
    if (mode_ == Mode::Transfer) {
      for (const auto& press : frame_keys_) transfer_->handle_key(press.key, press.mods);
      return;
    }
    if (pressed(GLFW_KEY_Z, kCtrl)) undo();
    if (pressed(GLFW_KEY_Z, kCtrl | GLFW_MOD_SHIFT) || pressed(GLFW_KEY_Y, kCtrl)) redo();
    if (pressed(GLFW_KEY_S, kCtrl)) save(output_path_);
    if (pressed(GLFW_KEY_S, kCtrl | GLFW_MOD_SHIFT)) request_save_as();
    if (pressed(GLFW_KEY_O, kCtrl)) request_open();
    if (pressed(GLFW_KEY_DELETE, kCtrl) && document_ && document_->handle_count() > 0) {
      finish_action("remove handle " + std::to_string(document_->active_handle() + 1), [this] { document_->remove_handle(document_->active_handle()); });
    }
    if (!document_) return;
    if (pressed(GLFW_KEY_F)) adjust_camera(false);
    for (const auto& press : frame_keys_) tools_.press(press.key, press.mods);
    if (pressed(GLFW_KEY_I)) layer_action("invert", [this](Layer layer) { document_->invert(layer); });
    if (pressed(GLFW_KEY_EQUAL)) layer_action("grow", [this](Layer layer) { document_->grow(layer); });
    if (pressed(GLFW_KEY_MINUS)) layer_action("shrink", [this](Layer layer) { document_->shrink(layer); });
    if (pressed(GLFW_KEY_LEFT_BRACKET)) brush_radius_ /= 1.25f;
    if (pressed(GLFW_KEY_RIGHT_BRACKET)) brush_radius_ *= 1.25f;
    if (pressed(GLFW_KEY_N)) {
      document_->add_handle();
      tools_.tool = Tool::PaintHandle;
    }
    if (pressed(GLFW_KEY_TAB) && document_->handle_count() > 0) {
      document_->set_active_handle((document_->active_handle() + 1) % static_cast<int>(document_->handle_count()));
    }
    if (pressed(GLFW_KEY_0)) finish_action("reset the handles", [this] { document_->reset_poses(); });
    if (pressed(GLFW_KEY_A)) apply();
    if (pressed(GLFW_KEY_W)) settings_.wireframe = !settings_.wireframe;
    if (pressed(GLFW_KEY_H)) {
      settings_.show_field = !settings_.show_field;
      view_dirty_ = true;
    }
    if (pressed(GLFW_KEY_K)) settings_.show_classes = !settings_.show_classes;
    if (pressed(GLFW_KEY_P)) show_profiler_ = !show_profiler_;
  }

  // Whether `key` was pressed since the last frame with exactly the modifiers `mods` (of Ctrl,
  // Shift and Alt).
  bool pressed(int key, int mods = 0) const {
    constexpr int kModifiers = GLFW_MOD_CONTROL | GLFW_MOD_SHIFT | GLFW_MOD_ALT;
    return std::any_of(frame_keys_.begin(), frame_keys_.end(), [&](const KeyPress& press) {
      return press.key == key && (press.mods & kModifiers) == mods;
    });
  }

  Eigen::ParametrizedLine<float, 3> cursor_ray(const ImVec2& cursor) const {
    const auto extent = target_->extent();
    const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
    return camera_.ray(cursor.x * scale.x, cursor.y * scale.y, static_cast<float>(extent.width), static_cast<float>(extent.height));
  }

  // The geometry on screen (the renderer's newest snapshot); the picker follows it.
  const engine::GeometrySnapshot* shown_geometry() {
    const engine::GeometrySnapshot* shown = exchange_ ? exchange_->acquire() : nullptr;
    if (shown == nullptr) return nullptr;
    if (!picker_) picker_ = std::make_unique<MeshPicker>(document_->rest().triangles, shown->position_normal);
    else if (picker_version_ != shown->version) picker_->refit(shown->position_normal);
    picker_version_ = shown->version;
    return shown;
  }

  void handle_mouse() {
    if (!document_) return;
    ImGuiIO& io = ImGui::GetIO();
    const ImVec2 mouse = io.MousePos;
    const ImVec2 delta = io.MouseDelta;
    const bool over_view = !io.WantCaptureMouse;

    // A camera drag that began over the view goes on over the panel.
    const CameraGesture gesture = camera_gesture_now();
    if (over_view || camera_drag_) {
      apply_camera_gesture(camera_, gesture, {delta.x, delta.y}, io.DisplaySize.y, over_view ? io.MouseWheel : 0.0f);
      camera_drag_ = gesture != CameraGesture::None;
    }
    if (io.KeyAlt) return;

    if (ImGui::IsMouseClicked(ImGuiMouseButton_Left) && over_view) {
      dragging_ = true;
      stroke_.clear();
      drag_cursor_ = mouse;
      lay_out_gizmo();
      gizmo_drag_ = gizmo_.hit({mouse.x, mouse.y});
      if (tools_.connected_armed) {
        tools_.connected_armed = false;
        dragging_ = false;
        paint_connected(mouse);
        return;
      }
    }
    if (!dragging_) return;
    if (ImGui::IsMouseReleased(ImGuiMouseButton_Left) || !ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
      dragging_ = false;
      gizmo_drag_ = GizmoPart::None;
      if (is_paint_tool(tools_.tool) && tools_.lasso) paint_lasso();
      commit_action(is_paint_tool(tools_.tool) ? std::string(tools_.erase ? "erase " : "paint ") + layer_name()
                                         : lowercase_first(tool_name(tools_.tool)) + " " + std::to_string(document_->active_handle() + 1));
      return;
    }
    if (is_paint_tool(tools_.tool)) {
      if (tools_.lasso) {
        if (stroke_.empty() || std::hypot(stroke_.back().x - mouse.x, stroke_.back().y - mouse.y) > 3.0f) stroke_.push_back(mouse);
      } else {
        paint_brush(mouse);
      }
      return;
    }
    continue_handle_drag(mouse, last_input_);
  }

  // Applies the cursor's move since the last one applied (from the frame or from the wait for the
  // device: each move counts once).
  void continue_handle_drag(const ImVec2& cursor, Clock::time_point event_time) {
    const ImVec2 delta(cursor.x - drag_cursor_.x, cursor.y - drag_cursor_.y);
    if (delta.x == 0.0f && delta.y == 0.0f) return;
    drag_handle(cursor, delta, event_time);
    drag_cursor_ = cursor;
  }

  // The brush on screen: its centre and radius in window pixels, its world size at the cursor's
  // depth on the mesh (painting through, at the view target's depth where the cursor misses it).
  std::optional<std::pair<ImVec2, float>> brush_on_screen(const ImVec2& mouse) {
    if (shown_geometry() == nullptr) return std::nullopt;
    const auto ray = cursor_ray(mouse);
    const auto hit = picker_->pick(ray);
    if (!hit && !tools_.paint_through) return std::nullopt;
    const Eigen::Vector3f point = hit ? hit->point : Eigen::Vector3f(ray.pointAt((camera_.target - camera_.position()).norm()));
    const Eigen::Vector3f right = (camera_.target - camera_.position()).cross(camera_.up_vector()).normalized();
    const ImVec2 centre = project(point);
    const ImVec2 edge = project(point + brush_radius_ * right);
    return std::pair{centre, std::hypot(edge.x - centre.x, edge.y - centre.y)};
  }

  void paint_brush(const ImVec2& mouse) {
    const auto* shown = shown_geometry();
    if (shown == nullptr) return;
    std::vector<int> vertices;
    if (tools_.paint_through) {
      // Everything under the brush's circle, front and back.
      const auto brush = brush_on_screen(mouse);
      if (!brush) return;
      const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
      const auto extent = target_->extent();
      vertices = vertices_in_screen_disc(shown->position_normal, Eigen::Vector2f(brush->first.x * scale.x, brush->first.y * scale.y), brush->second * scale.x,
                                         camera_.view_projection(static_cast<float>(extent.width) / static_cast<float>(extent.height)),
                                         static_cast<float>(extent.width), static_cast<float>(extent.height));
    } else {
      const auto hit = picker_->pick(cursor_ray(mouse));
      if (!hit) return;
      vertices = vertices_in_ball(shown->position_normal, hit->point, brush_radius_);
    }
    document_->paint(vertices, layer_of(tools_.tool), tools_.erase);
    view_dirty_ = true;
    recovery_dirty_ = true;
  }

  void paint_lasso() {
    const auto* shown = shown_geometry();
    if (shown == nullptr || stroke_.size() < 3) return;
    const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
    std::vector<Eigen::Vector2f> polygon;
    for (const auto& point : stroke_) polygon.emplace_back(point.x * scale.x, point.y * scale.y);
    const auto extent = target_->extent();
    const std::optional<Eigen::Vector3f> towards_viewer =
        tools_.paint_through ? std::nullopt : std::optional<Eigen::Vector3f>((camera_.position() - camera_.target).normalized());
    const auto vertices = vertices_in_lasso(shown->position_normal, polygon,
                                            camera_.view_projection(static_cast<float>(extent.width) / static_cast<float>(extent.height)),
                                            static_cast<float>(extent.width), static_cast<float>(extent.height), towards_viewer);
    document_->paint(vertices, layer_of(tools_.tool), tools_.erase);
    stroke_.clear();
    view_dirty_ = true;
  }

  void paint_connected(const ImVec2& mouse) {
    if (!is_paint_tool(tools_.tool) || shown_geometry() == nullptr) return;
    const auto hit = picker_->pick(cursor_ray(mouse));
    if (!hit) return;
    const auto vertices = connected_vertices(hit->vertex, document_->adjacency());
    finish_action(std::string(tools_.erase ? "erase " : "paint ") + "the connected part as " + layer_name(),
                  [&] { document_->paint(vertices, layer_of(tools_.tool), tools_.erase); });
  }

  // Moves the active handle by a mouse drag (or the benchmark's synthetic one).
  void drag_handle(const ImVec2& mouse, const ImVec2& delta, Clock::time_point event_time) {
    const int h = document_->active_handle();
    if (document_->handle_count() == 0 || document_->handle_size(h) == 0 || is_paint_tool(tools_.tool)) return;
    const HandleTransform& pose = document_->pose(h);
    DragStep step;
    step.from = cursor_ray(ImVec2(mouse.x - delta.x, mouse.y - delta.y));
    step.to = cursor_ray(mouse);
    step.cursor = Eigen::Vector2f(mouse.x, mouse.y);
    step.delta = Eigen::Vector2f(delta.x, delta.y);
    const Eigen::Vector3f eye = camera_.position();
    step.forward = (camera_.target - eye).normalized();
    step.right = step.forward.cross(camera_.up_vector()).normalized();
    step.up = step.right.cross(step.forward);
    const float depth = std::max((pose.pivot + pose.shift).cast<float>().dot(step.forward) - eye.dot(step.forward), 1e-6f);
    const float height = static_cast<float>(std::max(target_->extent().height, 1u)) / ImGui::GetIO().DisplayFramebufferScale.y;
    step.world_per_pixel = 2.0f * depth * std::tan(0.5f * camera_.fov_y) / height;
    step.project = [this](const Eigen::Vector3f& point) { return project_to_window(point); };
    step.ring_radius = 0.8f * gizmo_.length();
    const HandleTransform moved = drag_pose(pose, tools_, gizmo_drag_, step);
    document_->set_pose(h, moved.axis, moved.angle, moved.scale, moved.shift);
    note_pose_input(event_time);
    recovery_dirty_ = true;
  }

  std::optional<Eigen::Vector2f> project_to_window(const Eigen::Vector3f& point) const {
    const auto extent = target_->extent();
    const Eigen::Vector4f clip =
        camera_.view_projection(static_cast<float>(extent.width) / static_cast<float>(extent.height)) * Eigen::Vector4f(point.x(), point.y(), point.z(), 1.0f);
    if (clip.w() <= 1e-6f) return std::nullopt;
    const ImVec2 p = project(point);
    return Eigen::Vector2f(p.x, p.y);
  }

  ImVec2 project(const Eigen::Vector3f& point) const {
    const auto extent = target_->extent();
    const Eigen::Vector4f clip =
        camera_.view_projection(static_cast<float>(extent.width) / static_cast<float>(extent.height)) * Eigen::Vector4f(point.x(), point.y(), point.z(), 1.0f);
    const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
    return ImVec2((clip.x() / clip.w() * 0.5f + 0.5f) * static_cast<float>(extent.width) / scale.x,
                  (clip.y() / clip.w() * 0.5f + 0.5f) * static_cast<float>(extent.height) / scale.y);
  }

  void draw_overlays() {
    if (!document_ || view_only_screenshot()) return;
    ImDrawList* draw = ImGui::GetBackgroundDrawList();  // under the panel and the dialogs
    const ImVec2 mouse = ImGui::GetIO().MousePos;
    if (is_paint_tool(tools_.tool)) {
      if (tools_.lasso && stroke_.size() > 1) draw->AddPolyline(stroke_.data(), static_cast<int>(stroke_.size()), IM_COL32(255, 230, 60, 255), 0, 1.5f);
      if (!tools_.lasso && !ImGui::GetIO().WantCaptureMouse) {
        if (const auto brush = brush_on_screen(mouse)) {
          const ImU32 color = tools_.erase ? IM_COL32(255, 80, 80, 255) : tools_.paint_through ? IM_COL32(120, 220, 255, 255) : IM_COL32(255, 255, 255, 220);
          draw->AddCircle(brush->first, brush->second, color, 48, 1.5f);
          if (tools_.paint_through) draw->AddCircle(brush->first, brush->second - 3.0f, color, 48, 1.0f);
        }
      }
      return;
    }
    const int h = document_->active_handle();
    if (document_->handle_count() == 0 || document_->handle_size(h) == 0) return;
    const HandleTransform& pose = document_->pose(h);
    const Eigen::Vector3f centre = (pose.pivot + pose.shift).cast<float>();
    const ImVec2 c = project(centre);
    lay_out_gizmo();
    // Under the panel and the dialogs: the background list.
    ImDrawList* under = ImGui::GetBackgroundDrawList();
    if (gizmo_.laid_out()) {
      const GizmoPart lit = gizmo_drag_ != GizmoPart::None ? gizmo_drag_ : ImGui::GetIO().WantCaptureMouse ? GizmoPart::None : gizmo_.hit({mouse.x, mouse.y});
      gizmo_.draw(under, lit);
    } else {
      under->AddCircle(c, 6.0f, IM_COL32(255, 255, 255, 255), 16, 2.0f);
    }
    char text[128];
    std::snprintf(text, sizeof text, "%s%s  %.1f°  ×%.2f", tool_name(tools_.tool), tools_.lock_text().c_str(), pose.angle * 180.0 / std::numbers::pi, pose.scale);
    under->AddText(ImVec2(c.x + 10, c.y + 8), IM_COL32(255, 255, 255, 255), text);
  }

  // The gizmo of the active handle for the move and rotate tools: its axes turned with the
  // handle, 8% of the scene long, kept inside the view.
  void lay_out_gizmo() {
    const int h = document_->active_handle();
    if ((tools_.tool != Tool::Grab && tools_.tool != Tool::Rotate) || document_->handle_count() == 0 || document_->handle_size(h) == 0) {
      gizmo_ = HandleGizmo{};
      return;
    }
    const HandleTransform& pose = document_->pose(h);
    const Eigen::Matrix3f axes = pose.rotation().toRotationMatrix().cast<float>();
    const ImVec2 size = ImGui::GetIO().DisplaySize;
    gizmo_.layout([this](const Eigen::Vector3f& point) { return project_to_window(point); }, (pose.pivot + pose.shift).cast<float>(), axes,
                  0.08f * scene_size(), tools_.tool == Tool::Grab ? GizmoMode::Move : GizmoMode::Rotate, Eigen::Vector2f(kPanelWidth + 8.0f, 8.0f),
                  Eigen::Vector2f(size.x - 8.0f, size.y - 8.0f));
  }

  // ---- the drag benchmark ---------------------------------------------------------------------------

  // Drags the first handle back and forth along its pose (from the identity to the pose the
  // command line gave, or a default bend) through the same code as a mouse drag, then reports
  // frame times and input-to-screen latency and quits. The input comes like a mouse's: a thread
  // produces timestamped moves at 100 Hz, independent of the frames, and the loop takes them
  // whenever it gets to them; each move's latency runs from its timestamp to the first frame
  // that shows a solve including it.
  void benchmark_step() {
    if (!document_ || document_->solver_state() != Document::SolverState::Ready) return;
    if (!benchmark_) {
      benchmark_target_ = document_->pose(0);
      if (benchmark_target_.angle == 0.0 && benchmark_target_.shift.isZero()) {
        benchmark_target_ = HandleTransform::about_pivot(Eigen::Vector3d::UnitX(), benchmark_target_.pivot, 0.5, 1.0,
                                                         Eigen::Vector3d(0.0, 0.1 * scene_size(), 0.0));
      }
      document_->set_active_handle(0);
      statistics_.restart();
      benchmark_ = std::make_unique<SyntheticDrag>([] { glfwPostEmptyEvent(); });
      return;
    }
    if (seconds_since(benchmark_->started()) > options_.benchmark_drag_seconds) {
      benchmark_->stop();
      slots_->wait_all();
      note_finished_frames();
      finish_benchmark();
      return;
    }
    take_benchmark_input();
  }

  void take_benchmark_input() {
    const std::vector<Clock::time_point> events = benchmark_->take();
    if (events.empty()) return;
    // The newest move decides the pose; every move taken now is answered by this request.
    const auto pose = SyntheticDrag::pose_at(benchmark_target_, milliseconds_between(benchmark_->started(), events.back()) / 1000.0);
    document_->set_pose(0, pose.axis, pose.angle, pose.scale, pose.shift);
    note_pose_input(events);
  }

  void finish_benchmark() {
    const double seconds = seconds_since(benchmark_->started());
    benchmark_.reset();
    benchmark_done_ = true;
    const std::vector<double> frames = statistics_.frame_intervals();
    const std::vector<double> latencies = statistics_.latencies();
    const auto extent = target_->extent();
    nlohmann::json report = {{"command", "gui --benchmark-drag"},
                             {"mesh", mesh_name_},
                             {"vertices", document_->vertex_count()},
                             {"triangles", document_->rest().triangle_count()},
                             {"device", context_->device_name()},
                             {"width", extent.width},
                             {"height", extent.height},
                             {"samples", static_cast<int>(target_->format().samples)},
                             {"pacing", latch_solves_ ? "latch" : "free"},
                             {"seconds", seconds},
                             {"frames", frames.size()},
                             {"frames_per_second", static_cast<double>(frames.size()) / seconds},
                             {"frame_ms", to_json(summarize(frames))},
                             {"input_to_screen_ms", to_json(summarize(latencies))},
                             {"updates_shown", latencies.size()},
                             {"last_update_ms", document_->last_update_ms()},
                             {"validation_messages", context_->validation_message_count()}};
    if (!options_.benchmark_out.empty()) {
      const std::string text = report.dump(2) + "\n";
      write_file_atomically(options_.benchmark_out, [&](std::ostream& out) { out << text; });
    }
    print_json_line(report);
    quit_ = true;
  }

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
  std::unique_ptr<MeshPicker> picker_;
  std::uint64_t picker_version_ = 0;
  std::unique_ptr<RecoveryWriter> recovery_;

  BackgroundTask<Loaded> load_;  // reading a mesh or session and replaying it
  Clock::time_point build_started_{};

  engine::Camera camera_;
  engine::RenderSettings settings_;
  std::string mesh_name_;
  std::string output_path_;
  char path_buffer_[1024] = {};
  std::string status_;
  std::string error_message_;
  std::string open_failure_;
  std::string last_open_request_;  // the path last given to Open, a drop or the command line  // shown in the "Could not open" dialog until dismissed
  std::vector<std::string> dropped_paths_;
  Mode mode_ = Mode::Edit;
  std::unique_ptr<TransferView> transfer_;

  EditTools tools_;
  float brush_radius_ = 0.02f;
  bool dragging_ = false;
  bool camera_drag_ = false;
  ImVec2 drag_cursor_{};  // the cursor position the handle drag has applied up to
  std::vector<ImVec2> stroke_;
  bool view_dirty_ = true;
  struct KeyPress {
    int key;
    int mods;
  };
  InputQueue input_;  // from the window's callbacks, a frame's worth at a time
  ImGuiInputFeed imgui_input_;
  std::vector<KeyPress> frame_keys_;   // this frame's

  bool show_help_ = false;
  bool keep_recovery_ = false;
  std::uint64_t transfer_recovery_version_ = 0;  // the transfer state's version last written  // quit by a signal: the recovery file is what the next start offers
  std::optional<RestoreOffer> restore_offer_;  // the restore prompt is open
  std::string after_open_note_;                // said in the status line once the next document opens
  bool open_dialog_ = false;
  bool save_dialog_ = false;
  bool quit_dialog_ = false;
  bool quit_ = false;
  int exit_code_ = 0;
  std::array<float, 4> announced_pose_fields_{};
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
};

}  // namespace

int run_editor(const EditorOptions& options) {
  EditorApp app(options);
  return app.run();
}

}  // namespace hdeform::cli

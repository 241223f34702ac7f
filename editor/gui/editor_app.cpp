// The editor window: set-up, the frame loop, pacing and the drag benchmark (the frame itself: editor_frame.cpp).
#include "gui/editor_app_parts.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "commands/termination_signals.h"

namespace hdeform::cli::gui {

namespace {

// SIGTERM, SIGINT and SIGHUP ask the editor to write its recovery file and quit: the next start
// offers it. They are taken by a thread of their own (termination_signals.h), which wakes the
// frame loop; it acts on them.
class QuitSignals {
 public:
  QuitSignals() { claim_termination_signals([] { glfwPostEmptyEvent(); }); }
  ~QuitSignals() { release_termination_signals(); }
  QuitSignals(const QuitSignals&) = delete;
  QuitSignals& operator=(const QuitSignals&) = delete;
  static int received() { return termination_signal(); }
};

}  // namespace

int EditorApp::run() {
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
    const bool busy = (!input_.empty() && !saving()) || dragging_ || benchmark_ || screenshot_requested_ || (transfer_ && transfer_->busy()) ||
                      (document_ && document_->last_published_request() != shown_tag_) || (target_ && target_->scene_build().slices > 0) ||
                      panel_behind_picture_;
    // A set-up in progress only changes the panel's progress line, which a frame a second shows
    // well enough. Polling drew frame after frame instead, and on a CPU device each frame of a
    // large mesh took the cores from the set-up (the 3.3M Buddha on lavapipe: half a second a
    // frame; drag-ready after 18.5 s, where `edit` needs 7.9 s). Loading likewise changes only
    // the progress overlay, four times a second, and its end wakes the loop: polled, the overlay
    // alone took a core from the load and the set-up beside it (2,700–2,900 frames before the
    // 13M Buddha was installed). So does writing a mesh's buffers (staged_), whose end wakes the
    // loop too.
    const bool setting_up = document_ && document_->solver_state() == Document::SolverState::Building;
    if (busy) glfwPollEvents();
    else {
      // Idle, but a frame of the proxy may be waiting to be replaced by the whole mesh.
      double timeout = setting_up ? 1.0 : 0.25;
      if (const auto rest = motion_detail_.until_rest(Clock::now())) timeout = std::min(timeout, std::chrono::duration<double>(*rest).count());
      glfwWaitEventsTimeout(timeout);
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

void EditorApp::create_window() {
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

void EditorApp::queue_input(GLFWwindow* window, InputEvent event) {
  event.time = Clock::now();
  auto* app = static_cast<EditorApp*>(glfwGetWindowUserPointer(window));
  app->input_.push(event);
  app->last_input_ = event.time;
}

void EditorApp::create_renderer() {
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
      samples, false, !single_threaded_vulkan());
  slots_ = std::make_unique<engine::FrameSlots>(*context_, frames_in_flight());
  if (!single_threaded_vulkan()) slots_->enable_completion_times();
  latch_solves_ = options_.pacing == "latch" || (options_.pacing == "auto" && context_->is_cpu_device());
  // A GPU draws a scan's picture within a frame; a CPU device takes seconds (scene_slices.h).
  slice_triangles_ = options_.slice_triangles >= 0 ? static_cast<std::size_t>(options_.slice_triangles)
                     : context_->is_cpu_device() ? kSliceTriangles
                                                 : 0;
  renderer_ = std::make_unique<engine::MeshRenderer>(*context_, target_->render_pass(), target_->format(), slots_->count());
  transfer_ = std::make_unique<TransferView>(*context_, target_->render_pass(), target_->format(), slots_->count(), chosen_up_axis());

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
  info.MSAASamples = VK_SAMPLE_COUNT_1_BIT;  // drawn in the overlay pass, over the resolved scene
  info.CheckVkResultFn = [](VkResult result) { engine::check(result, "Dear ImGui (Vulkan)"); };
  ImGui_ImplVulkan_Init(&info, target_->overlay_pass());
  imgui_vulkan_started_ = true;
  context_->submit_and_wait([](VkCommandBuffer commands) { ImGui_ImplVulkan_CreateFontsTexture(commands); });
  ImGui_ImplVulkan_DestroyFontUploadObjects();
}

// The validation layers packaged in Debian 12 (1.3.239) track semaphores and queues with known
// races when the application calls Vulkan from several threads (our reading; not reproduced here):
// the editor, started under validation some hundred times by CI's ThreadSanitizer suite, once threw
// std::future_error ("No associated state") out of a Vulkan call (our code uses no futures) before
// its first picture. So under validation (the tests, --validation) only the rendering thread calls
// Vulkan: it presents itself, and no thread waits for frames to finish (no frame times or
// input-to-screen figures). Without validation, as the user runs it, a thread presents and another
// times the frames; test_window runs those threads without validation.
bool EditorApp::single_threaded_vulkan() const { return context_->validation_enabled(); }

uint32_t EditorApp::frames_in_flight() const {
  if (const char* value = std::getenv("HDEFORM_FRAMES_IN_FLIGHT")) return std::clamp(std::atoi(value), 1, 3);
  return context_->is_cpu_device() ? 1 : engine::kFramesInFlight;
}

void EditorApp::set_mode(Mode mode) {
  if (mode == mode_) return;
  mode_ = mode;
  // The other mode's picture does not stand for this one while a scan's is drawn in slices.
  target_->drop_scene();
  glfwSetWindowTitle(window_, mode_ == Mode::Transfer ? "hdeform — transfer" : ("hdeform — " + mesh_name_).c_str());
}

void EditorApp::shutdown() {
  benchmark_.reset();  // its thread wakes the window system: stopped before that goes
  transfer_.reset();
  if (context_) vkDeviceWaitIdle(context_->device());
  document_.reset();  // stops its pipeline before the publisher goes; a set-up runs on, let go
  // Work nobody wants any more is let go of, not waited for (left_running); none of it calls
  // back into the window system once abandoned.
  retiring_.abandon();
  load_.abandon();
  drop_staged();  // its buffers go before the renderer and the device
  proxy_task_.abandon();
  save_task_.finish();  // a save being written is finished first
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
    print_json_line({{"event", "exit"},
                     {"validation_messages", context_->validation_message_count()},
                     {"frames", frames_drawn_},
                     {"scene_frames", scene_frames_}});
  }
  context_.reset();
  if (window_ != nullptr) glfwDestroyWindow(window_);
  window_ = nullptr;
  if (glfw_started_) glfwTerminate();
  glfw_started_ = false;
}

void EditorApp::wait_for_device() {
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

void EditorApp::take_input_while_waiting() {
  glfwPollEvents();
  if (dragging_ && !is_paint_tool(tools_.tool)) {
    double x = 0.0, y = 0.0;
    glfwGetCursorPos(window_, &x, &y);
    continue_handle_drag(ImVec2(static_cast<float>(x), static_cast<float>(y)), last_input_);
  }
  if (benchmark_) take_benchmark_input();
}

void EditorApp::note_pose_input(std::span<const Clock::time_point> events) {
  for (std::size_t k = 0; k < events.size(); ++k) trace::instant("pose input", "input");
  unposted_events_.insert(unposted_events_.end(), events.begin(), events.end());
  if (!latch_solves_) post_pending_solve();
}

std::uint64_t EditorApp::post_pending_solve() {
  if (unposted_events_.empty()) return 0;
  const std::uint64_t request = post_request(unposted_events_);
  unposted_events_.clear();
  return request;
}

void EditorApp::step() {
  finish_save();
  // While a save is written, input waits in its queue: nothing may change what is being saved.
  const std::vector<InputEvent> events = saving() ? std::vector<InputEvent>{} : input_.take_frame();
  frame_keys_.clear();
  frame_pointer_path_.clear();
  for (const InputEvent& event : events) {
    if (event.kind == InputEvent::Kind::Key && event.action == GLFW_PRESS) frame_keys_.push_back({event.code, event.mods});
    if (event.kind == InputEvent::Kind::Move) frame_pointer_path_.emplace_back(static_cast<float>(event.x), static_cast<float>(event.y));
  }
  finish_load();
  finish_proxy();
  prepare_picking();
  if (!dropped_paths_.empty() && !saving()) {
    if (mode_ == Mode::Transfer) transfer_->drop(dropped_paths_, ImGui::GetIO().MousePos);
    else open_path(dropped_paths_.front());
    dropped_paths_.clear();
  }
  transfer_->poll();
  write_transfer_recovery();
  if (document_) {
    const auto before = document_->solver_state();
    document_->hold_set_up(dragging_ && is_paint_tool(tools_.tool));
    document_->poll();
    // On a CPU device (latch pacing) iterations would take the cores a drag's frames need: they
    // wait until its input rests (buddha-206k on lavapipe: 17.7 fps and 99 ms input to screen
    // with iterations between the drag's updates, against 29.7 fps and 52 ms without). Once the
    // handle (or a value in the panel, dragged or typed) is let go nothing more comes from it, and
    // they start at once.
    const bool input_held = handle_dragged() || ImGui::IsAnyItemActive();
    document_->set_refinement_delay(std::chrono::milliseconds(latch_solves_ && input_held ? kRefineAfterRestMs : 0));
    // ... and each frame of a settling shape takes them from the iterations: a few per second.
    document_->set_refinement_publication_interval(std::chrono::milliseconds(latch_solves_ ? kRefinementFrameMs : 0));
    if (document_->solver_state() != before) {
      view_dirty_ = true;
      announce_solver_state();
    }
    // A refinement that settles is announced once: scripts and tests wait for it before they
    // take a picture of the result (until then each iteration replaces the last on screen). Once
    // per request: the next one's may settle before a step sees it unsettled (a reset settles at
    // its first publication, right after the paper's update).
    if (document_->refine()) {
      const auto view = document_->refinement();
      const auto& status = view.status;
      // (Its digest comes a moment after it finishes: the announcement waits for it.)
      if (view.finished && !view.digest.empty() && view.request != announced_refinement_) {
        announced_refinement_ = view.request;
        print_json_line({{"event", "refined"},
                         {"iterations", status.iterations},
                         {"energy", status.energy},
                         {"unrefined_energy", status.unrefined_energy},
                         {"converged", status.converged},
                         {"settled", status.settled},
                         {"positions_digest", view.digest}});
      }
    }
    // ... and so is an answer that failed (settled(): nothing more comes for these poses).
    if (const auto failure = document_->answer_failure(); !failure.why.empty() && failure.request != announced_failure_) {
      announced_failure_ = failure.request;
      print_json_line({{"event", "error"}, {"message", failure.why}});
    }
    finish_pending_save();
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

void EditorApp::announce_solver_state() {
  switch (document_->solver_state()) {
    case Document::SolverState::Ready:
      solver_warnings_ = document_->warnings();
      print_json_line({{"event", "solver"}, {"state", "ready"}, {"factor_ms", document_->setup_timings()->factor_ms}, {"warnings", solver_warnings_}});
      break;
    case Document::SolverState::Failed:
      print_json_line({{"event", "solver"}, {"state", "failed"}, {"message", document_->solver_message()}});
      break;
    case Document::SolverState::NoHandle: print_json_line({{"event", "solver"}, {"state", "no handle"}}); break;
    case Document::SolverState::Building: break;
  }
}

void EditorApp::sync_view() {
  if (!document_ || !view_dirty_) return;
  const trace::Scope traced("classes and field to the renderer", "frame");
  view_dirty_ = false;
  // Into buffers kept from the last call: new ones cost their pages' first writes every time (at
  // 13 million triangles 53 MB, which held the window for a good part of 0.3 s).
  const auto n = static_cast<int>(document_->vertex_count());
  view_classes_.assign(static_cast<std::size_t>(n), HD_CLASS_FREE);
  const bool region = document_->has_region_of_interest();
  for (int v = 0; v < n; ++v) {
    const int label = document_->label(v);
    if (label >= 0) view_classes_[static_cast<std::size_t>(v)] = engine::handle_class(static_cast<std::size_t>(label));
    else if (label == Document::kFixed) view_classes_[static_cast<std::size_t>(v)] = engine::fixed_class();
    else if (region && !document_->in_region_of_interest(v)) view_classes_[static_cast<std::size_t>(v)] = engine::outside_class();
  }
  renderer_->set_classes(view_classes_);
  if (const Eigen::VectorXd* field = document_->field()) {
    view_field_.resize(static_cast<std::size_t>(field->size()));
    Eigen::Map<Eigen::VectorXf>(view_field_.data(), field->size()) = field->cast<float>();
    renderer_->set_field(view_field_);
  } else {
    renderer_->set_field({});
  }
}

void EditorApp::benchmark_step() {
  if (!document_ || document_->solver_state() != Document::SolverState::Ready) return;
  if (settle_started_) {
    // Released: the loop runs as for a user (frames as results land) until the shape settles.
    if (document_->settled() || seconds_since(*settle_started_) > kSettleTimeout) finish_benchmark();
    return;
  }
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
    drag_report_ = drag_figures(seconds_since(benchmark_->started()));
    benchmark_.reset();
    if (!document_->refine()) return finish_benchmark();
    // The release, at the target pose: how long until the refinement settles on screen.
    const HandleTransform& target = benchmark_target_;
    document_->set_pose(0, target.axis, target.angle, target.scale, target.shift);
    settle_started_ = Clock::now();
    note_pose_input(*settle_started_);
    post_pending_solve();
    return;
  }
  take_benchmark_input();
}

void EditorApp::take_benchmark_input() {
  const std::vector<Clock::time_point> events = benchmark_->take();
  if (events.empty()) return;
  // The newest move decides the pose; every move taken now is answered by this request.
  const auto pose = SyntheticDrag::pose_at(benchmark_target_, milliseconds_between(benchmark_->started(), events.back()) / 1000.0);
  document_->set_pose(0, pose.axis, pose.angle, pose.scale, pose.shift);
  note_pose_input(events);
}

nlohmann::json EditorApp::drag_figures(double seconds) const {
  const std::vector<double>& frames = statistics_.recorded_frame_intervals();
  const std::vector<double>& latencies = statistics_.recorded_latencies();
  const auto extent = target_->extent();
  return {{"command", "gui --benchmark-drag"},
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
          {"last_update_ms", document_->last_update_ms()}};
}

void EditorApp::finish_benchmark() {
  benchmark_done_ = true;
  nlohmann::json report = drag_report_.is_null() ? drag_figures(seconds_since(benchmark_->started())) : drag_report_;
  benchmark_.reset();
  if (settle_started_) {
    // From the release to the step that found the refinement settled; that step's frame draws it.
    const auto view = document_->refinement();
    report["settle"] = {{"ms", seconds_since(*settle_started_) * 1000.0},
                        {"settled", document_->settled()},
                        {"iterations", view.status.iterations},
                        {"iteration_ms", view.iteration_ms},
                        {"energy", view.status.energy},
                        {"unrefined_energy", view.status.unrefined_energy},
                        {"refine_settle", document_->refine_settle()}};
    settle_started_.reset();
  }
  report["validation_messages"] = context_->validation_message_count();
  if (!options_.benchmark_out.empty()) {
    const std::string text = report.dump(2) + "\n";
    write_file_atomically(options_.benchmark_out, [&](std::ostream& out) { out << text; });
  }
  print_json_line(report);
  quit_ = true;
}

}  // namespace hdeform::cli::gui

namespace hdeform::cli {

int run_editor(const EditorOptions& options) {
  int exit_code = 0;
  {
    gui::EditorApp app(options);
    exit_code = app.run();
  }
  // Everything the user's work needs is written and the window is gone. Work let go of may still
  // run (a set-up's stage cannot stop partway: seconds to a minute at scan resolution), and the
  // process ends without waiting for it, nor for the static destructors that it may still use.
  if (left_running::count() > 0) {
    std::cout.flush();
    std::cerr.flush();
    std::fflush(nullptr);
    std::_Exit(exit_code);
  }
  return exit_code;
}

}  // namespace hdeform::cli

// The editor window: starting documents, the recovery files and the restore prompt, actions and undo, saving.
#include "gui/editor_app_parts.h"

#include <nlohmann/json.hpp>

namespace hdeform::cli::gui {

namespace {
// A session file and its mesh, the session's lists checked against the mesh: every problem names
// the file's line. The mesh is moved out, never copied (79 MB at 3.3 million triangles).
std::pair<Session, Mesh> read_session_and_mesh(const std::string& path) {
  SessionSource source;
  Session session = read_session(path, &source);
  Mesh mesh = load_session_mesh(session, &source);
  return {std::move(session), std::move(mesh)};
}
}  // namespace

void EditorApp::start_from_options() {
  if (!options_.transfer.source_rest.empty() || !options_.transfer.target.empty()) {
    set_mode(Mode::Transfer);
    transfer_->open(options_.transfer);
  }
  recent_ = std::make_unique<RecentFiles>((options_.recovery_file.empty() ? default_recovery_path() : options_.recovery_file).parent_path() / "recent.json");
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

std::filesystem::path EditorApp::transfer_recovery_path() const {
  const auto& path = recovery_->path();
  return path.parent_path() / (path.stem().string() + "-transfer.json");
}

void EditorApp::remove_recovery_files() {
  std::error_code ignored;
  std::filesystem::remove(recovery_->path(), ignored);
  std::filesystem::remove(transfer_recovery_path(), ignored);
}

void EditorApp::restore_transfer_mode() {
  if (!std::filesystem::exists(transfer_recovery_path())) return;
  try {
    transfer_->restore(read_transfer_state(transfer_recovery_path()));
    set_mode(Mode::Transfer);
  } catch (const std::exception& error) {
    error_message_ = std::string("Transfer mode was not restored: ") + error.what();
  }
}

void EditorApp::write_transfer_recovery() {
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

void EditorApp::offer_restore() {
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

void EditorApp::answer_restore(RestoreChoice choice) {
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

void EditorApp::restore_recovery() {
  const auto path = recovery_->path();
  start_load("the recovered session", [path] { return read_session_and_mesh(path); }, true);
}

void EditorApp::start_requested_document() {
  const EditorOptions options = options_;
  last_open_request_ = !options.session.empty() ? options.session : options.mesh;
  const std::string what = !options.session.empty() ? options.session : options.mesh.empty() ? std::string("the cactus") : options.mesh;
  start_load(what, [options] {
    if (!options.session.empty()) {
      auto [session, mesh] = read_session_and_mesh(options.session);
      return std::tuple{std::move(session), std::move(mesh), std::string()};
    }
    Session session;
    session.current.refine = options.refine;
    session.current.refine_settle = kEditorSettle;
    session.mesh = options.mesh.empty() ? "shape:cactus" : options.mesh;
    if (!names_builtin_shape(session.mesh)) session.mesh = std::filesystem::absolute(session.mesh).lexically_normal().string();
    LoadedMesh loaded = load_mesh(MeshSource::from_name(session.mesh));
    Mesh mesh = std::move(loaded.mesh);
    if (loaded.demo_constraints && options.handles.empty()) {
      // A built-in shape starts with its demo's source and sink painted, ready to drag.
      session.current.fixed = loaded.demo_constraints->fixed;
      session.current.handles.push_back({loaded.demo_constraints->handles[0], pose_for(loaded.demo_constraints->handles[0], mesh, {})});
    }
    // A list that cannot be used leaves the mesh open without the lists (the user sees why).
    const EditStage painted = session.current;
    std::string problem;
    try {
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
    } catch (const InputError& error) {
      session.current = painted;
      problem = std::string(error.what()) + ". " + std::filesystem::path(session.mesh).filename().string() +
                " is open without the vertex lists given with it: paint them, or open it again with lists that fit.";
    }
    return std::tuple{std::move(session), std::move(mesh), std::move(problem)};
  });
}

HandleTransform EditorApp::pose_for(const std::vector<int>& vertices, const Mesh& mesh, const std::optional<HandleTransform>& target) {
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
  for (const int v : vertices) pivot += mesh.positions.row(v).transpose();
  pivot /= static_cast<double>(vertices.size());
  if (!target) return HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), pivot, 0.0);
  const Eigen::Vector3d shift = target->apply(pivot) - pivot;
  return HandleTransform::about_pivot(target->axis, pivot, target->angle, target->scale, shift);
}

void EditorApp::prepare_picking() {
  // Once the cores are free of the proxy, the solver's set-up and a drag or its refinement, so as
  // not to slow them: the picker, and the adjacency that Grow, Shrink and Connected use.
  if (!document_ || proxy_task_.running() || dragging_ || benchmark_) return;
  const auto state = document_->solver_state();
  if (state == Document::SolverState::Building || (state == Document::SolverState::Ready && !document_->settled())) return;
  if (!picker_.prepared()) picker_.prepare(document_->shared_rest());
  document_->prepare_adjacency();
}

float EditorApp::panel_fraction() const {
  const auto extent = target_->extent();
  return extent.width > 0 ? std::min(kPanelWidth * ImGui::GetIO().DisplayFramebufferScale.x / static_cast<float>(extent.width), 0.9f) : 0.0f;
}

void EditorApp::adjust_camera(bool reset_angles) {
  if (!document_) return;
  const auto extent = target_->extent();
  const float aspect = extent.height > 0 ? static_cast<float>(extent.width) / static_cast<float>(extent.height) : 1.0f;
  if (reset_angles) {
    camera_ = engine::Camera::three_quarter_front(engine::Bounds::of(document_->rest().positions), up_axis(), aspect, panel_fraction());
    return;
  }
  // Fit: the shape as it is on screen, deformed, and the rest shape only while nothing is shown.
  // (Not shown_geometry(): fitting needs no picker, whose build would hold this frame up for a
  // second at 3.3 million triangles before the background build has begun.)
  engine::Bounds bounds;
  if (const engine::GeometrySnapshot* shown = shown_snapshot(); shown != nullptr && !shown->position_normal.empty()) {
    const auto& values = shown->position_normal;
    bounds.min = bounds.max = Eigen::Vector3f(values[0], values[1], values[2]);
    for (std::size_t k = 0; k + 2 < values.size(); k += 6) {
      const Eigen::Vector3f p(values[k], values[k + 1], values[k + 2]);
      bounds.min = bounds.min.cwiseMin(p);
      bounds.max = bounds.max.cwiseMax(p);
    }
  } else {
    bounds = engine::Bounds::of(document_->rest().positions);
  }
  camera_.covered_left = panel_fraction();
  camera_.fit(bounds, aspect);
}

std::optional<engine::UpAxis> EditorApp::chosen_up_axis() const {
  if (options_.up == "y") return engine::UpAxis::Y;
  if (options_.up == "z") return engine::UpAxis::Z;
  return std::nullopt;
}

std::string EditorApp::default_output_path() const {
  std::error_code ignored;
  const std::filesystem::path folder = !save_folder_.empty() ? save_folder_ : std::filesystem::current_path(ignored);
  if (names_builtin_shape(mesh_name_)) return (folder / (MeshSource::from_name(mesh_name_).shape_name + "-edited.obj")).string();
  const std::filesystem::path input(mesh_name_);
  // The result keeps the input's format where it is one that is written (PLY), else OBJ.
  const std::string extension = mesh_format_of(input) == MeshFormat::Ply ? input.extension().string() : ".obj";
  return (folder / (input.stem().string() + "-edited" + extension)).string();
}

std::string EditorApp::PendingAction::describe() const {
  return kind == Kind::Quit ? std::string("Quitting") : "Opening " + std::filesystem::path(path).filename().string();
}

UnsavedWork EditorApp::unsaved_work() const {
  UnsavedWork work;
  if (document_ && document_->modified()) work.edits = "the edits of " + std::filesystem::path(mesh_name_).filename().string();
  if (transfer_) work.markers = transfer_->unsaved_markers();
  return work;
}

void EditorApp::ask_or_run(const PendingAction& action) {
  if (options_.benchmark_drag_seconds > 0.0 || !unsaved_work().any()) return run_action(action);
  asked_ = action;
}

void EditorApp::run_action(const PendingAction& action) {
  if (action.kind == PendingAction::Kind::Quit) quit_ = true;
  else open_now(action.path);
}

void EditorApp::answer_unsaved(UnsavedChoice choice) {
  const PendingAction action = *std::exchange(asked_, std::nullopt);
  if (choice == UnsavedChoice::Cancel) {
    status_ = action.describe() + ": cancelled";
    return;
  }
  if (choice == UnsavedChoice::Discard) return run_action(action);
  // Save: the markers where they were saved before (else Save as, and the action waits for the
  // user to ask again), then the edits; the action follows the last save written.
  if (transfer_ && !transfer_->unsaved_markers().empty() && !transfer_->save_markers_in_place()) {
    status_ = "Choose where the marker pairs go, then " + lowercase_first(action.describe()) + " again";
    return;
  }
  if (document_ && document_->modified()) {
    after_save_ = action;
    save(output_path_);
    return;
  }
  run_action(action);
}

void EditorApp::open_path(const std::string& path) { ask_or_run({PendingAction::Kind::Open, path}); }

void EditorApp::open_now(const std::string& path) {
  last_open_request_ = path;
  if (path.ends_with(".json")) {
    start_load(path, [path] { return read_session_and_mesh(path); });
    return;
  }
  start_load(path, [path, refine = options_.refine] {
    Session session;
    session.current.refine = refine;
    session.current.refine_settle = kEditorSettle;
    session.mesh = names_builtin_shape(path) ? path : std::filesystem::absolute(path).lexically_normal().string();
    Mesh mesh = load_session_mesh(session);
    return std::pair{std::move(session), std::move(mesh)};
  });
}

void EditorApp::commit_action(const std::string& what) {
  if (!document_) return;
  document_->commit(what);
  view_dirty_ = true;
  post_recovery();
}

std::string EditorApp::layer_name() const {
  switch (layer_of(tools_.tool)) {
    case Layer::RegionOfInterest: return "the region of interest";
    case Layer::Fixed: return "fixed";
    case Layer::Handle: return "handle " + std::to_string(document_->active_handle() + 1);
  }
  return "";
}

void EditorApp::undo() {
  if (!document_) return;
  if (document_->undo()) after_history_step("Undone: " + document_->last_history_step());
  else status_ = "Nothing to undo";
}

void EditorApp::redo() {
  if (!document_) return;
  if (document_->redo()) after_history_step("Redone: " + document_->last_history_step());
  else status_ = "Nothing to redo";
}

void EditorApp::after_history_step(const std::string& what) {
  view_dirty_ = true;
  publish_rest_if_needed();
  post_request(Clock::now());
  post_recovery();
  status_ = what;
}

void EditorApp::apply() {
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

void EditorApp::publish_rest_if_needed() {
  if (document_->solver_state() == Document::SolverState::NoHandle || document_->handle_count() == 0) publisher_->publish(document_->rest().positions, 0);
}

std::uint64_t EditorApp::post_request(std::span<const Clock::time_point> events) {
  if (!document_) return 0;
  // While a handle is dragged the frames draw the proxy: the answer need hold only its vertices
  // (the pipeline publishes the whole shape once the input rests).
  const std::uint64_t request = document_->request_update(motion_detail_.enabled() && handle_dragged());
  if (request == 0) return 0;
  statistics_.note_request(request, events);
  return request;
}

void EditorApp::post_recovery() {
  if (!document_ || !recovery_) return;
  recovery_->post(document_->session());
  last_recovery_ = Clock::now();
  recovery_dirty_ = false;
}

void EditorApp::save(const std::string& path) {
  if (!document_ || path.empty()) return;
  pending_save_ = path;
  finish_pending_save();
  if (pending_save_) status_ = "Saving " + std::filesystem::path(path).filename().string() + " once the shape settles (refining)...";
}

void EditorApp::finish_pending_save() {
  if (!pending_save_ || !document_ || !document_->settled() || saving()) return;
  start_save(*std::exchange(pending_save_, std::nullopt));
}

void EditorApp::start_save(const std::string& path) {
  Mesh result;
  try {
    // Settled: the pipeline's last answer, the shape on screen (a failed set-up has none).
    result = Mesh{document_->result(), document_->rest().triangles};
  } catch (const std::exception& error) {
    return fail_save(error.what());
  }
  const std::string name = std::filesystem::path(path).filename().string();
  status_ = "Saving " + name + "...";
  saving_path_ = path;
  saving_session_ = document_->session();
  save_task_.start("Saving " + name, [mesh = std::move(result), session = saving_session_, path] {
    const trace::Scope traced("save", "io");
    write_mesh(path, mesh);
    write_session(session_path_for(path), session);
    return positions_digest(mesh.positions);
  }, [] { glfwPostEmptyEvent(); });
}

void EditorApp::fail_save(const std::string& why) {
  save_failure_ = why;
  error_message_ = "Not saved: " + save_failure_;
  status_.clear();
  print_json_line({{"event", "error"}, {"message", error_message_}});
  after_save_.reset();
}

void EditorApp::finish_save() {
  if (!save_task_.done()) return;
  auto outcome = save_task_.take();
  const std::string path = std::exchange(saving_path_, {});
  if (!outcome.result) return fail_save(outcome.error);
  if (document_) document_->mark_saved(saving_session_);
  output_path_ = path;
  save_folder_ = std::filesystem::absolute(path).parent_path();
  // File names only: a long path wraps the footer over the panel's controls.
  status_ = "Saved " + std::filesystem::path(path).filename().string() + " and " + std::filesystem::path(session_path_for(path)).filename().string();
  error_message_.clear();
  print_json_line({{"event", "saved"}, {"obj", path}, {"session", session_path_for(path)}, {"positions_digest", *outcome.result}});
  if (after_save_) run_action(*std::exchange(after_save_, std::nullopt));
}

void EditorApp::quit_on_signal(int signal) {
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

void EditorApp::request_quit() { ask_or_run({PendingAction::Kind::Quit, {}}); }

}  // namespace hdeform::cli::gui

// The editor window: the side panel (controls, pose fields, live figures, status) and the dialogs.
#include "gui/editor_app_parts.h"
#include "hdeform/counted.h"

#include <nlohmann/json.hpp>

#include <cstdio>

namespace hdeform::cli::gui {

void EditorApp::draw_panel() {
  ImGui::SetNextWindowPos(ImVec2(0, 0));
  ImGui::SetNextWindowSize(ImVec2(kPanelWidth, ImGui::GetIO().DisplaySize.y));
  ImGui::Begin("hdeform", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  const bool editing = mode_ == Mode::Edit;
  const float wrap = ImGui::GetContentRegionAvail().x;
  const auto wrapped_height = [wrap](const std::string& text) { return text.empty() ? 0.0f : ImGui::CalcTextSize(text.c_str(), nullptr, false, wrap).y; };
  const ImGuiStyle& style = ImGui::GetStyle();
  const int figure_lines = editing && document_ ? (motion_detail_.enabled() ? 6 : 5) : 0;  // draw_footer's lines of figures
  float notes = 0.0f;
  for (const auto& note : shown_notes()) notes += wrapped_height(note) + style.ItemSpacing.y;
  if (const std::string failure = solver_failure(); !failure.empty()) notes += wrapped_height(failure) + style.ItemSpacing.y;
  const float footer = editing ? style.ItemSpacing.y * 4 + style.WindowPadding.y + wrapped_height(status_) + wrapped_height(error_message_) + notes +
                                     static_cast<float>(figure_lines) * ImGui::GetTextLineHeightWithSpacing()
                               : 0.0f;
  ImGui::BeginChild("controls", ImVec2(0, -footer));
  draw_controls();
  ImGui::EndChild();
  if (editing) draw_footer();
  ImGui::End();
}

void EditorApp::draw_footer() {
  ImGui::Separator();
  if (document_) {
    if (const DeformerTimings* timings = document_->setup_timings()) ImGui::Text("Factorization: %.1f ms", timings->factor_ms);
    else ImGui::TextDisabled("Factorization: -");
    ImGui::Text("Last update: %.2f ms", document_->last_update_ms());
    ImGui::Text("Frames: %zu per second", statistics_.frames_per_second(Clock::now()));
    ImGui::Text("Frame: %s", percentile_text(statistics_.frame_intervals()).c_str());
    ImGui::Text("Input to screen: %s", percentile_text(statistics_.latencies()).c_str());
    if (motion_detail_.enabled()) ImGui::TextDisabled("While moving: a %d-triangle proxy", static_cast<int>(proxy_triangle_count_));
  }
  if (!status_.empty()) ImGui::TextWrapped("%s", status_.c_str());  // (an empty one would still take a line)
  for (const auto& note : shown_notes()) wrapped_in_color(ImVec4(1.0f, 0.8f, 0.3f, 1.0f), note);
  if (const std::string failure = solver_failure(); !failure.empty()) wrapped_in_color(ImVec4(1, 0.45f, 0.45f, 1), failure);
  if (!error_message_.empty()) wrapped_in_color(ImVec4(1, 0.45f, 0.45f, 1), error_message_);
}

void EditorApp::draw_controls() {
  int mode = mode_ == Mode::Transfer ? 1 : 0;
  ImGui::RadioButton("Edit", &mode, 0);
  ImGui::SameLine();
  ImGui::RadioButton("Transfer (Ctrl+T)", &mode, 1);
  set_mode(mode == 1 ? Mode::Transfer : Mode::Edit);
  ImGui::Separator();
  if (mode_ == Mode::Transfer) {
    transfer_->draw_panel(dialog_keys());
    return;
  }
  ImGui::TextWrapped("%s", !mesh_name_.empty() ? mesh_name_.c_str()
                                      : load_.running() || staged_ ? "(loading)"
                                      : restore_offer_ ? "Restore the last session? (the question in the middle)"
                                                       : "No mesh open: Open... or drop a mesh file here (OBJ, PLY, OFF, STL)");
  if (document_) ImGui::Text("%ld vertices, %ld triangles", static_cast<long>(document_->vertex_count()), static_cast<long>(document_->rest().triangle_count()));
  if (ImGui::Button("Open...")) request_open();
  ImGui::SameLine();
  if (ImGui::Button("Save")) save(output_path_);
  if (ImGui::IsItemHovered() && document_) ImGui::SetTooltip("Saves to %s\n(and its session beside it; Save as chooses another)", output_path_.c_str());
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
    const std::size_t size = document_->handle_size(h);
    const std::string label = "Handle " + std::to_string(h + 1) + " (" + counted(size, "vertex", "vertices") + ")";
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
  std::vector<SolverBackend> backends;
  std::vector<const char*> backend_names;
  int backend = 0;
  for (const auto choice : kSolverBackends) {
    if (!backend_available(choice)) continue;
    if (choice == document_->options().backend) backend = static_cast<int>(backends.size());
    backends.push_back(choice);
    backend_names.push_back(to_string(choice).data());  // the names are string literals
  }
  if (ImGui::Combo("Backend", &backend, backend_names.data(), static_cast<int>(backend_names.size()))) {
    DeformerOptions solver_options = document_->options();
    solver_options.backend = backends[static_cast<std::size_t>(backend)];
    document_->set_options(solver_options);
  }
  draw_solve_choice();
  if (document_->factor_precision() == FactorPrecision::Single) {
    const auto refinement = document_->factor_refinement();
    if (refinement.solves > 0) {
      ImGui::TextWrapped("Single precision: %.2f correction steps a solve",
                         static_cast<double>(refinement.corrections) / static_cast<double>(refinement.solves));
    } else {
      ImGui::TextUnformatted("Single precision");
    }
    if (ImGui::IsItemHovered()) {
      ImGui::SetTooltip("The factor is stored in single precision (half its memory); each solve is refined against the\n"
                        "double matrix until its residual is at double accuracy. Saved with the session.");
    }
  }
  switch (document_->solver_state()) {
    case Document::SolverState::NoHandle: ImGui::TextWrapped("Paint a handle (3) to deform."); break;
    case Document::SolverState::Building:
      ImGui::TextWrapped("%s...", document_->solver_message().c_str());
      if (document_->drags_previous_selection()) wrapped_in_color(ImGui::GetStyleColorVec4(ImGuiCol_TextDisabled), "Dragging with the previous set-up until then.");
      break;
    case Document::SolverState::Failed: break;  // in the footer (solver_failure), always in view
    case Document::SolverState::Ready: break;
  }

  bool refine = document_->refine();
  const bool toggled = ImGui::Checkbox("Refine (as rigid as possible)", &refine);
  announce_refine_toggle();
  if (toggled) {
    document_->set_refine(refine);
    document_->commit(refine ? "refinement on" : "refinement off");
    // The poses asked again with the new setting: off, the paper's result goes back on screen; on,
    // the shape settles as for any request, and settled() (what Save waits for) can say so.
    document_->request_update();
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
    if (status.iterations == 0 && !view.finished) {
      ImGui::TextDisabled("Refinement: waiting for the update");
    } else {
      ImGui::Text("Refinement: %d iterations%s", status.iterations,
                  status.converged ? ", settled" : view.finished ? ", stopped at the cap" : "...");
      // Wrapped: at the panel's width a scan's figures ran past its edge.
      ImGui::TextWrapped("Energy %.4g (paper's %.4g, %.1f ms each)", status.energy, status.unrefined_energy, view.iteration_ms);
    }
    if (ImGui::IsItemHovered()) {
      ImGui::SetTooltip("Settled: an iteration would move no vertex by more than %g of the bounding box's diagonal\n"
                        "(edit --refine auto --refine-settle %g gives the same shape; its own default stop is tighter).",
                        document_->refine_settle(), document_->refine_settle());
    }
  }
  ImGui::Checkbox("Profiler (P)", &show_profiler_);
  ImGui::Checkbox("Solve before each frame", &latch_solves_);
  if (ImGui::IsItemHovered()) {
    ImGui::SetTooltip("On: a frame waits up to %.0f ms for the solve of the newest input (best on a CPU device).\n"
                      "Off: frames never wait; each shows the newest finished solve.", kMaxLatchMs);
  }
}

void EditorApp::draw_solve_choice() {
  const Document::SolveChoice now = document_->solve_choice();
  const bool changeable = document_->can_change_solve_choice();
  // Shown after the disabled part ends: a tooltip drawn inside it would be faded as well.
  const char* tip = nullptr;
  const char* kNotChangeable = "The applied stages were solved this way; solving elsewhere would change the rest shape.\n"
                               "Undo the Apply to choose again.";
  ImGui::BeginDisabled(!changeable);
  int site = now.resolution == Resolution::Multiresolution ? 0 : 1;
  const char* sites[] = {"a base mesh", "every vertex"};
  if (ImGui::Combo("Solve on", &site, sites, 2) && (site == 0) != (now.resolution == Resolution::Multiresolution)) {
    Document::SolveChoice choice = now;
    choice.resolution = site == 0 ? Resolution::Multiresolution : Resolution::Exact;
    // A base as large as the mesh would be the mesh again, solved the long way round.
    if (choice.resolution == Resolution::Multiresolution && choice.base_vertices >= document_->vertex_count()) {
      choice.base_vertices = std::max<Eigen::Index>(4, document_->vertex_count() / 4);
    }
    // Every vertex of a scan is a much larger solve: asked first.
    if (choice.resolution == Resolution::Exact && document_->vertex_count() >= kMultiresolutionFrom) confirm_exact_ = choice;
    else change_solve_choice(choice);
  }
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) {
    tip = changeable ? "A base mesh: the update and the refinement solve on a simplified mesh, and the fine detail\n"
                       "follows it in local frames (fixed and handle vertices stay exact). Every vertex: the paper's\n"
                       "solve on the whole mesh. Saved with the session; undoable."
                     : kNotChangeable;
  }
  if (now.resolution == Resolution::Multiresolution) {
    if (!base_vertices_editing_) base_vertices_field_ = static_cast<int>(now.base_vertices);
    ImGui::InputInt("Base size", &base_vertices_field_, 0, 0);
    base_vertices_editing_ = ImGui::IsItemActive();
    if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) {
      tip = changeable ? "The base mesh's vertices (Enter applies; the base may keep a few more to keep the mesh's topology)" : kNotChangeable;
    }
    if (ImGui::IsItemDeactivatedAfterEdit()) {
      Document::SolveChoice choice = now;
      choice.base_vertices = std::clamp<Eigen::Index>(base_vertices_field_, 4, std::max<Eigen::Index>(4, document_->vertex_count()));
      if (choice != now) change_solve_choice(choice);
    }
  }
  bool single = now.precision == FactorPrecision::Single;
  if (ImGui::Checkbox("Single-precision factor", &single)) {
    Document::SolveChoice choice = now;
    choice.precision = single ? FactorPrecision::Single : FactorPrecision::Double;
    change_solve_choice(choice);
  }
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) {
    tip = changeable ? "The factor is stored in single precision (half its memory); each solve is refined against the\n"
                       "double matrix until its residual is at double accuracy. Saved with the session; undoable."
                     : kNotChangeable;
  }
  ImGui::EndDisabled();
  if (tip != nullptr) ImGui::SetTooltip("%s", tip);
  // What solves the drag now: the set-up in place, which until a new one is ready may be of an
  // earlier choice.
  const Eigen::Index solved = document_->solved_vertex_count(), all = document_->vertex_count();
  if (solved == 0) ImGui::TextWrapped("Solves on %s", solve_site_text(now).c_str());
  else if (solved < all) ImGui::TextWrapped("Solved on a base of %ld of the %ld vertices", static_cast<long>(solved), static_cast<long>(all));
  else ImGui::TextWrapped("Solved on all %ld vertices", static_cast<long>(all));
}

std::string EditorApp::solve_site_text(const Document::SolveChoice& choice) const {
  std::string text = choice.resolution == Resolution::Exact ? "every vertex" : "a base of " + std::to_string(choice.base_vertices) + " vertices";
  if (choice.precision == FactorPrecision::Single) text += ", single-precision factor";
  return text;
}

void EditorApp::change_solve_choice(const Document::SolveChoice& choice) {
  const std::string what = "solve on " + solve_site_text(choice);
  finish_action(what, [&] { document_->set_solve_choice(choice); });
  status_ = "From now on: " + what + " (Ctrl+Z goes back)";
}

void EditorApp::draw_exact_confirmation() {
  constexpr const char* kTitle = "Solve on every vertex?";
  if (confirm_exact_ && !ImGui::IsPopupOpen(kTitle)) {
    ImGui::OpenPopup(kTitle);
    print_json_line({{"event", "dialog"}, {"title", kTitle}});
  }
  if (!ImGui::BeginPopupModal(kTitle, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  if (!confirm_exact_ || !document_) {  // the mesh it asked about was replaced (a file dropped on the window)
    ImGui::CloseCurrentPopup();
    ImGui::EndPopup();
    return;
  }
  const bool keys = !ImGui::IsWindowAppearing();
  ImGui::PushTextWrapPos(ImGui::GetFontSize() * 36.0f);
  const Eigen::Index solved = document_ ? document_->solved_vertex_count() : 0;
  ImGui::Text("The solve on all %ld vertices factors the whole mesh, where the base has %ld.", static_cast<long>(document_->vertex_count()),
              static_cast<long>(solved > 0 ? solved : confirm_exact_->base_vertices));
  ImGui::TextUnformatted("At this size its set-up takes many times longer and needs many times the memory, and each drag step is "
                         "slower. Until it is ready the drag goes on with the base; Ctrl+Z goes back.");
  ImGui::PopTextWrapPos();
  std::optional<bool> answer;
  if (ImGui::Button("Solve on every vertex (Enter)") || (keys && (pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER)))) answer = true;
  ImGui::SameLine();
  if (ImGui::Button("Cancel (Esc)") || (keys && pressed(GLFW_KEY_ESCAPE))) answer = false;
  if (answer) {
    ImGui::CloseCurrentPopup();
    print_json_line({{"event", "dialog closed"}, {"title", kTitle}, {"choice", *answer ? "exact" : "cancel"}});
    const Document::SolveChoice choice = *confirm_exact_;
    confirm_exact_.reset();
    if (*answer && document_->can_change_solve_choice()) change_solve_choice(choice);
  }
  ImGui::EndPopup();
}

void EditorApp::draw_pose_editor() {
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

void EditorApp::announce_pose_fields() {
  const ImVec2 at = ImGui::GetCursorScreenPos();
  const std::array<float, 4> layout{at.x, at.y, ImGui::CalcItemWidth(), ImGui::GetFrameHeightWithSpacing()};
  if (layout == announced_pose_fields_) return;
  announced_pose_fields_ = layout;
  print_json_line({{"event", "pose fields"}, {"x", layout[0]}, {"y", layout[1]}, {"width", layout[2]}, {"row", layout[3]}});
}

void EditorApp::announce_refine_toggle() {
  const ImVec2 low = ImGui::GetItemRectMin(), high = ImGui::GetItemRectMax();
  const std::array<float, 4> box{low.x, low.y, high.x - low.x, high.y - low.y};
  if (box == announced_refine_toggle_) return;
  announced_refine_toggle_ = box;
  print_json_line({{"event", "refine toggle"}, {"x", box[0]}, {"y", box[1]}, {"width", box[2]}, {"height", box[3]}});
}

void EditorApp::draw_dialogs() {
  if (show_help_ && pressed(GLFW_KEY_ESCAPE) && !ImGui::IsPopupOpen(nullptr, ImGuiPopupFlags_AnyPopupId)) show_help_ = false;
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
  const bool busy = saving() || load_.running() || (document_ && document_->solver_state() == Document::SolverState::Building) || transfer_work;
  const double busy_for = saving()        ? save_task_.seconds()
                          : transfer_work ? transfer_work->second
                          : load_.running() ? load_.seconds()
                                        : (build_started_ != Clock::time_point{} ? seconds_since(build_started_) : 0.0);
  // The first picture of a mesh drawn in slices (scene_slices.h): nothing shows it until the last.
  const engine::SwapchainTarget::SceneBuild build = target_->scene_build();
  const bool first_picture = mode_ != Mode::Transfer && document_ && !target_->scene_kept() && build.slices > 0;
  const bool staging_shown = staged_ && (staged_->announced || stage_.seconds() > kProgressDelay);
  if ((busy && busy_for > kProgressDelay) || staging_shown || first_picture) {
    const char* spinner = "|/-\\";
    const std::string what = saving()        ? save_task_.what()
                             : transfer_work ? transfer_work->first
                             : load_.running() ? load_.what()
                                           : document_ ? document_->solver_message() : std::string();
    char line[512];
    if (staging_shown && !saving() && !transfer_work) {
      std::snprintf(line, sizeof line, "%s: %d%%", stage_.what().c_str(), static_cast<int>(100.0 * staged_->done->load()));
    } else if (first_picture && !saving() && !transfer_work) {
      std::snprintf(line, sizeof line, "Drawing %s: %d%%", std::filesystem::path(mesh_name_).filename().c_str(),
                    static_cast<int>(100.0 * engine::share_before({build.next, build.slices, scene_ramp_})));
    } else {
      std::snprintf(line, sizeof line, "%c %s  (%.1f s)", spinner[static_cast<int>(busy_for * 8) % 4], what.c_str(), busy_for);
    }
    // Sized for this frame's line: an auto-sized window fits the line of the frame before, and
    // while a large mesh is set up a frame comes once a second, so a longer line showed cut off.
    const ImVec2 padding = ImGui::GetStyle().WindowPadding;
    const ImVec2 text = ImGui::CalcTextSize(line);
    const ImVec2 size = ImGui::GetIO().DisplaySize;
    ImGui::SetNextWindowSize(ImVec2(text.x + 2.0f * padding.x, text.y + 2.0f * padding.y), ImGuiCond_Always);
    ImGui::SetNextWindowPos(ImVec2(size.x * 0.5f + kPanelWidth * 0.5f, size.y * 0.5f), ImGuiCond_Always, ImVec2(0.5f, 0.5f));
    ImGui::Begin("Working", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoInputs);
    ImGui::TextUnformatted(line);
    ImGui::End();
  }
  if (restore_offer_) {
    const RestoreChoice choice = restore_prompt(*restore_offer_, pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER), pressed(GLFW_KEY_ESCAPE));
    if (choice != RestoreChoice::Undecided) answer_restore(choice);
  }
  draw_open_failure();
  if (open_dialog_ && recent_shown_.empty() && recent_) recent_shown_ = recent_->list();
  if (!open_dialog_) recent_shown_.clear();
  if (const auto path = path_prompt("Open", open_dialog_, path_buffer_, pressed(GLFW_KEY_ESCAPE), recent_shown_)) open_path(*path);
  if (const auto path = path_prompt("Save as", save_dialog_, path_buffer_, pressed(GLFW_KEY_ESCAPE))) save(*path);
  draw_save_failure();
  draw_exact_confirmation();
  if (asked_) {
    const UnsavedChoice choice =
        unsaved_prompt(asked_->describe(), unsaved_work(), dialog_keys());
    if (choice != UnsavedChoice::Undecided) answer_unsaved(choice);
  }
}

void EditorApp::draw_save_failure() {
  constexpr const char* kTitle = "Could not save";
  if (!save_failure_.empty() && !ImGui::IsPopupOpen(kTitle)) {
    ImGui::OpenPopup(kTitle);
    print_json_line({{"event", "dialog"}, {"title", kTitle}, {"message", save_failure_}});
  }
  if (!ImGui::BeginPopupModal(kTitle, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  const bool keys = !ImGui::IsWindowAppearing();  // not the Enter that confirmed Save as
  ImGui::PushTextWrapPos(ImGui::GetFontSize() * 36.0f);
  ImGui::TextUnformatted(save_failure_.c_str());
  ImGui::TextDisabled("Nothing was written. The edits are still here, and in the recovery file.");
  ImGui::PopTextWrapPos();
  const auto close = [this] {
    save_failure_.clear();
    ImGui::CloseCurrentPopup();
  };
  if (ImGui::Button("Save as... (Enter)") || (keys && (pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER)))) {
    close();
    request_save_as();
  }
  ImGui::SameLine();
  if (ImGui::Button("Close (Esc)") || (keys && pressed(GLFW_KEY_ESCAPE))) close();
  ImGui::EndPopup();
}

void EditorApp::request_open() {
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

void EditorApp::request_save_as() {
  std::snprintf(path_buffer_, sizeof path_buffer_, "%s", output_path_.c_str());
  save_dialog_ = true;
}

void EditorApp::draw_open_failure() {
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

// The ready deformer's findings about the mesh and the selection, in the footer: always in view.
std::vector<std::string> EditorApp::shown_notes() const {
  std::vector<std::string> notes;
  if (!document_ || document_->solver_state() != Document::SolverState::Ready) return notes;
  for (const auto& warning : solver_warnings_) notes.push_back("Note: " + warning);
  return notes;
}

std::string EditorApp::solver_failure() const {
  if (!document_) return {};
  if (document_->solver_state() == Document::SolverState::Failed) return document_->solver_message();
  if (std::string why = document_->answer_failure().why; !why.empty()) return why;
  return {};
}

}  // namespace hdeform::cli::gui

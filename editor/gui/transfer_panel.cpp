// Transfer mode's panel (meshes, markers, the transfer, the sequence) and the overlays over its
// two views.
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <filesystem>

#include "commands/cli_support.h"
#include "gui/transfer_view_parts.h"
#include "gui/widgets.h"
#include "hdeform/counted.h"

namespace hdeform::cli {

void TransferView::draw_panel(const DialogKeys& keys) {
  const bool escape_pressed = keys.escape;
  ImGui::TextDisabled("Meshes");
  ImGui::InputText("Source rest", source_path_, sizeof source_path_);
  ImGui::InputText("Source poses", poses_path_, sizeof poses_path_);
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("Paths separated by spaces; a name with * or ? matches files in its folder");
  ImGui::InputText("Target", target_path_, sizeof target_path_);
  ImGui::InputText("Markers file", markers_file_, sizeof markers_file_);
  ImGui::RadioButton("source in column 1", &source_column_, 1);
  ImGui::SameLine();
  ImGui::RadioButton("2", &source_column_, 2);
  if (ImGui::Button("Load")) {
    try {
      open_or_ask({source_path_, target_path_, expand_paths(poses_path_), markers_file_, source_column_});
    } catch (const std::exception& error) {
      error_ = error.what();
    }
  }
  if (asked_open_) {
    const UnsavedChoice choice = unsaved_prompt("Loading " + std::filesystem::path(asked_open_->source_rest).filename().string() + " and " +
                                                    std::filesystem::path(asked_open_->target).filename().string(),
                                                {"", unsaved_markers()}, keys);
    if (choice != UnsavedChoice::Undecided) {
      const TransferPaths inputs = *std::exchange(asked_open_, std::nullopt);
      if (choice == UnsavedChoice::Discard || (choice == UnsavedChoice::Save && save_markers_in_place())) open(inputs);
      if (choice == UnsavedChoice::Save && !unsaved_markers().empty()) status_ = "Choose where the marker pairs go, then load again";
    }
  }
  if (!sides_[0]) {
    ImGui::TextWrapped("Or drop mesh files on the views: the source rest (then its poses) on the left, the target on the right.");
    if (!error_.empty()) wrapped_in_color(ImVec4(1, 0.45f, 0.45f, 1), error_);
    return;
  }
  ImGui::Text("source %ld vertices, %zu poses; target %ld vertices", static_cast<long>(sides_[0]->rest.vertex_count()), poses_.size(),
              static_cast<long>(sides_[1]->rest.vertex_count()));
  for (int s = 0; s < 2; ++s) {
    Side& side = *sides_[s];
    int up = side.up == engine::UpAxis::Y ? 1 : 0;
    ImGui::TextUnformatted(s == 0 ? "Source up:" : "Target up:");
    ImGui::SameLine(100);
    bool changed = ImGui::RadioButton((std::string("z##up") + std::to_string(s)).c_str(), &up, 0);
    ImGui::SameLine();
    changed |= ImGui::RadioButton((std::string("y##up") + std::to_string(s)).c_str(), &up, 1);
    if (changed) {
      set_up(s, up == 1 ? engine::UpAxis::Y : engine::UpAxis::Z);
      publish_markers();
    }
  }

  ImGui::Separator();
  ImGui::TextDisabled("Markers");
  ImGui::Text("%zu pairs", markers_.size());
  ImGui::SameLine();
  if (ImGui::Button("Undo") && markers_.undo()) publish_markers();
  ImGui::SameLine();
  if (ImGui::Button("Redo") && markers_.redo()) publish_markers();
  ImGui::SameLine();
  if (ImGui::Button("Save")) {
    if (markers_path_.empty()) save_as_open_ = true;
    else save_markers(markers_path_);
  }
  ImGui::SameLine();
  if (ImGui::Button("Save as...")) {
    copy_text(dialog_path_, sizeof dialog_path_, markers_path_);
    save_as_open_ = true;
  }
  int labels = static_cast<int>(labels_);
  ImGui::TextUnformatted("Numbers:");
  ImGui::SameLine();
  ImGui::RadioButton("selected", &labels, static_cast<int>(MarkerLabels::Selected));
  ImGui::SameLine();
  ImGui::RadioButton("all", &labels, static_cast<int>(MarkerLabels::All));
  ImGui::SameLine();
  ImGui::RadioButton("none", &labels, static_cast<int>(MarkerLabels::None));
  labels_ = static_cast<MarkerLabels>(labels);
  ImGui::BeginChild("marker list", ImVec2(0, 120), true);
  for (std::size_t k = 0; k < markers_.size(); ++k) {
    const std::string label = std::to_string(k + 1) + ":  " + std::to_string(markers_.pairs().source[k]) + "  <->  " +
                              std::to_string(markers_.pairs().target[k]) + "##marker" + std::to_string(k);
    if (ImGui::Selectable(label.c_str(), selected_ == static_cast<int>(k))) selected_ = static_cast<int>(k);
  }
  ImGui::EndChild();
  if (selected_ >= 0 && ImGui::Button("Delete selected (Del)")) {
    markers_.remove(static_cast<std::size_t>(selected_));
    selected_ = -1;
    publish_markers();
  }

  ImGui::Separator();
  ImGui::TextDisabled("Transfer");
  if (ImGui::RadioButton("Correspondence (6)", &method_, 0)) ++settings_version_;
  ImGui::SameLine();
  if (ImGui::RadioButton("Interpolation (7)", &method_, 1)) ++settings_version_;
  if (method_ == 0) {
    if (ImGui::SliderInt("Top n (0: all)", &top_n_, 0, static_cast<int>(std::max<std::size_t>(markers_.size(), 3)))) ++settings_version_;
    if (top_n_ > 0 && top_n_ < 3) top_n_ = 3;
    if (ImGui::SliderFloat("Mismatch beyond", &mismatch_threshold_, 0.01f, 1.0f, "%.3f")) ++settings_version_;
  }
  ImGui::BeginDisabled(working() || markers_.size() < kMinimumMarkers);
  if (ImGui::Button("Compute (F5)")) start_compute();
  ImGui::EndDisabled();
  if (computed_) {
    ImGui::Text("Set-up %.0f ms, %.2f ms per pose", computed_->setup.total_ms, computed_->pose_ms.median);
    ImGui::Text("%zu factorizations, %zu mismatched triangles", computed_->factorizations, computed_->mismatches);
    if (stale()) ImGui::TextColored(ImVec4(1, 0.8f, 0.3f, 1), "Markers changed: compute again");
    for (const auto& warning : computed_->warnings) ImGui::TextWrapped("%s", warning.c_str());
  }

  if (!poses_.empty()) {
    ImGui::Separator();
    ImGui::TextDisabled("Sequence");
    if (ImGui::Button(playing_ ? "Pause (Space)" : "Play (Space)")) {
      playing_ = !playing_;
      if (playing_ && frame_ < 0) frame_ = 0;
      last_advance_ = std::chrono::steady_clock::now();
    }
    ImGui::SameLine();
    ImGui::SetNextItemWidth(120);
    ImGui::SliderFloat("fps", &frames_per_second_, 1.0f, 60.0f, "%.0f");
    // Counted from 1, as the pose files are; 0 is the rest shape.
    int pose = frame_ + 1;
    if (ImGui::SliderInt("Pose (0: rest)", &pose, 0, static_cast<int>(poses_.size()))) frame_ = pose - 1;
    if (frame_ >= 0) ImGui::Text("Pose %d of %zu: %s", frame_ + 1, poses_.size(), pose_names_[static_cast<std::size_t>(frame_)].c_str());
    else ImGui::TextUnformatted("The rest shapes");
    ImGui::BeginDisabled(!computed_ || stale());
    if (ImGui::Button("Export sequence...")) export_open_ = true;
    ImGui::EndDisabled();
  }
  ImGui::Separator();
  ImGui::TextWrapped("%s", status_.c_str());
  if (!error_.empty()) wrapped_in_color(ImVec4(1, 0.45f, 0.45f, 1), error_);

  if (const auto path = path_prompt("Save markers as", save_as_open_, dialog_path_, escape_pressed)) save_markers(*path);
  if (const auto folder = path_prompt("Export sequence to folder", export_open_, dialog_path_, escape_pressed)) export_sequence(*folder);
}

// ---- unsaved marker pairs: what Load, a drop and Quit ask about --------------------------------

std::string TransferView::unsaved_markers() const {
  if (!sides_[0] || markers_.version() == saved_markers_version_) return "";
  return counted(markers_.size(), "marker pair", "marker pairs") +
         (markers_path_.empty() || !std::filesystem::exists(markers_path_) ? " (never saved)"
                                                                          : " (changed since " + std::filesystem::path(markers_path_).filename().string() + ")");
}

bool TransferView::save_markers_in_place() {
  if (markers_path_.empty()) {
    save_as_open_ = true;
    return false;
  }
  save_markers(markers_path_);
  return markers_.version() == saved_markers_version_;
}

void TransferView::open_or_ask(const TransferPaths& inputs) {
  if (unsaved_markers().empty()) return open(inputs);
  asked_open_ = inputs;
}

void TransferView::draw_overlays() {
  if (!sides_[0]) return;
  ImDrawList* draw = ImGui::GetBackgroundDrawList();  // under the panel and the dialogs
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  auto window = [&](const ImVec2& pixel) { return ImVec2(pixel.x / scale.x, pixel.y / scale.y); };
  for (int s = 0; s < 2; ++s) {
    const VkRect2D& area = sides_[s]->area;
    const ImVec2 corner = window(ImVec2(static_cast<float>(area.offset.x), static_cast<float>(area.offset.y)));
    const std::string title = std::string(s == 0 ? "Source: " : "Target: ") + std::filesystem::path(sides_[s]->path).filename().string();
    draw->AddText(ImVec2(corner.x + 10, corner.y + 8), IM_COL32(40, 40, 40, 255), title.c_str());
    if (s == 1) draw->AddLine(corner, ImVec2(corner.x, corner.y + static_cast<float>(area.extent.height) / scale.y), IM_COL32(90, 90, 90, 255), 1.0f);
    const auto& vertices = s == 0 ? markers_.pairs().source : markers_.pairs().target;
    for (std::size_t k = 0; k < vertices.size(); ++k) {
      const bool selected = static_cast<int>(k) == selected_;
      if (!selected && labels_ != MarkerLabels::All) continue;
      const int vertex = drag_ && drag_->pair == k && drag_->side == s ? drag_->vertex : vertices[k];
      const ImVec2 at = window(project(s, shown_positions(s).row(vertex).transpose()));
      if (labels_ != MarkerLabels::None) draw->AddText(ImVec2(at.x + 6, at.y - 14), IM_COL32(20, 20, 20, 255), std::to_string(k + 1).c_str());
      if (selected) draw->AddCircle(at, 9.0f, IM_COL32(255, 255, 255, 255), 20, 2.5f);
    }
    if (pending_ && pending_->side == s) {
      const ImVec2 at = window(project(s, shown_positions(s).row(pending_->vertex).transpose()));
      draw->AddCircle(at, 11.0f, IM_COL32(255, 220, 60, 255), 20, 2.5f);
    }
  }
}

}  // namespace hdeform::cli

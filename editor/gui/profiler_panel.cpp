#include "profiler_panel.h"

#include <imgui.h>

#include <algorithm>
#include <numeric>

namespace hdeform::cli {
namespace {

double median_of(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

// Distinct colours for up to eight stages (viridis-like, readable on the panel's dark ground).
ImU32 stage_colour(std::size_t k) {
  static const ImU32 colours[] = {IM_COL32(68, 119, 170, 255), IM_COL32(102, 204, 238, 255), IM_COL32(34, 136, 51, 255),
                                  IM_COL32(204, 187, 68, 255),  IM_COL32(238, 102, 119, 255), IM_COL32(170, 51, 119, 255),
                                  IM_COL32(187, 187, 187, 255), IM_COL32(255, 153, 51, 255)};
  return colours[k % (sizeof colours / sizeof colours[0])];
}

void draw_series(const StageSeries& series) {
  ImGui::TextUnformatted(series.title().c_str());
  const auto& bars = series.bars();
  const ImVec2 size(ImGui::GetContentRegionAvail().x * 0.62f, 90.0f);
  const ImVec2 origin = ImGui::GetCursorScreenPos();
  ImDrawList* draw = ImGui::GetWindowDrawList();
  draw->AddRectFilled(origin, ImVec2(origin.x + size.x, origin.y + size.y), IM_COL32(20, 20, 24, 255));
  const double scale = series.scale();
  if (!bars.empty() && scale > 0.0) {
    const float width = size.x / static_cast<float>(std::max<std::size_t>(bars.size(), 100));
    float x = origin.x + size.x - width * static_cast<float>(bars.size());
    for (const auto& bar : bars) {
      float y = origin.y + size.y;
      for (std::size_t k = 0; k < bar.stages.size(); ++k) {
        const float height = static_cast<float>(std::min(bar.stages[k] / scale, 1.2) * size.y);
        const float top = std::max(origin.y, y - height);
        if (top < y) draw->AddRectFilled(ImVec2(x, top), ImVec2(x + std::max(width - 0.5f, 1.0f), y), stage_colour(k));
        y = top;
      }
      x += width;
    }
  }
  ImGui::Dummy(size);
  ImGui::SameLine();
  ImGui::BeginGroup();
  const auto medians = series.medians();
  for (std::size_t k = 0; k < series.stage_names().size(); ++k) {
    const ImVec2 at = ImGui::GetCursorScreenPos();
    draw->AddRectFilled(ImVec2(at.x, at.y + 3), ImVec2(at.x + 9, at.y + 12), stage_colour(k));
    ImGui::Dummy(ImVec2(12, 0));
    ImGui::SameLine();
    ImGui::Text("%-16s %6.2f ms", series.stage_names()[k].c_str(), medians[k]);
  }
  ImGui::Text("%-18s %6.2f ms", "total (median)", medians.back());
  ImGui::Text("%zu shown, top at %.1f ms", bars.size(), scale);
  ImGui::EndGroup();
}

}  // namespace

StageSeries::StageSeries(std::string title, std::vector<std::string> stage_names, std::size_t capacity)
    : title_(std::move(title)), names_(std::move(stage_names)), capacity_(capacity) {}

void StageSeries::add(std::vector<double> stages) {
  stages.resize(names_.size(), 0.0);
  bars_.push_back({std::move(stages)});
  while (bars_.size() > capacity_) bars_.pop_front();
}

std::vector<double> StageSeries::medians() const {
  std::vector<double> medians;
  std::vector<double> values, totals;
  for (std::size_t k = 0; k < names_.size(); ++k) {
    values.clear();
    for (const auto& bar : bars_) values.push_back(bar.stages[k]);
    medians.push_back(median_of(values));
  }
  for (const auto& bar : bars_) totals.push_back(std::accumulate(bar.stages.begin(), bar.stages.end(), 0.0));
  medians.push_back(median_of(totals));
  return medians;
}

double StageSeries::scale() const {
  std::vector<double> totals;
  for (const auto& bar : bars_) totals.push_back(std::accumulate(bar.stages.begin(), bar.stages.end(), 0.0));
  if (totals.empty()) return 0.0;
  std::sort(totals.begin(), totals.end());
  return totals[std::min(totals.size() - 1, static_cast<std::size_t>(0.95 * static_cast<double>(totals.size())))];
}

ProfilerPanel::ProfilerPanel()
    : updates_("Drag updates", {"field", "maps", "targets", "right-hand side", "solve", "write-back"}),
      refinement_("Refinement iterations", {"right-hand side", "solve", "acceleration", "rotations"}),
      frames_("Frames", {"processor", "device"}) {}

void ProfilerPanel::add_update(const UpdateTimings& t) { updates_.add({t.field_ms, t.maps_ms, t.targets_ms, t.rhs_ms, t.solve_ms, t.write_ms}); }

void ProfilerPanel::add_refinement(const RefinementTimings& t) { refinement_.add({t.rhs_ms, t.solve_ms, t.acceleration_ms, t.rotations_ms}); }

void ProfilerPanel::add_frame(double cpu_ms, double device_ms) { frames_.add({cpu_ms, device_ms}); }

void ProfilerPanel::draw(bool& open) const {
  if (!open) return;
  // At first in the bottom right corner: clear of the side panel and of the help list.
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  const ImVec2 size(620, 400);
  ImGui::SetNextWindowPos(ImVec2(std::max(0.0f, display.x - 16.0f - size.x), std::max(0.0f, display.y - 16.0f - size.y)), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(size, ImGuiCond_FirstUseEver);
  if (ImGui::Begin("Profiler (P)", &open)) {
    draw_series(updates_);
    ImGui::Separator();
    draw_series(refinement_);
    ImGui::Separator();
    draw_series(frames_);
    ImGui::TextDisabled("Stages overlap where they run in parallel (maps with targets); bars are stacked as if in turn.");
  }
  ImGui::End();
}

}  // namespace hdeform::cli

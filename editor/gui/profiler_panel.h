#pragma once
// The profiler panel: the last few hundred drag updates, refinement iterations and frames as
// stacked bars of their stages, each stage's median beside, so that one sees at a glance which
// stage grows with a bigger region or a bigger mesh. The data comes in as plain timings (from the
// document's pipeline and the frame slots); drawing is Dear ImGui's.
#include <deque>
#include <string>
#include <vector>

#include "hdeform/deformer.h"

namespace hdeform::cli {

// One bar: the named stages' milliseconds, stacked in the series' order.
struct StageBar {
  std::vector<double> stages;
};

// A series of bars with named, coloured stages, the newest `capacity` kept.
class StageSeries {
 public:
  StageSeries(std::string title, std::vector<std::string> stage_names, std::size_t capacity = 300);
  void add(std::vector<double> stages);
  const std::deque<StageBar>& bars() const { return bars_; }
  const std::vector<std::string>& stage_names() const { return names_; }
  const std::string& title() const { return title_; }
  // The median of each stage over the bars held, and of their totals (the last entry).
  std::vector<double> medians() const;
  // The height the plot is scaled to: the 95th percentile of the totals (a rare spike does not
  // flatten the rest).
  double scale() const;

 private:
  std::string title_;
  std::vector<std::string> names_;
  std::size_t capacity_;
  std::deque<StageBar> bars_;
};

class ProfilerPanel {
 public:
  ProfilerPanel();
  void add_update(const UpdateTimings& timings);
  void add_refinement(const RefinementTimings& timings);
  void add_frame(double cpu_ms, double device_ms);
  // The window (while `open`); its close button clears `open`.
  void draw(bool& open) const;

  const StageSeries& updates() const { return updates_; }
  const StageSeries& refinement() const { return refinement_; }
  const StageSeries& frames() const { return frames_; }

 private:
  StageSeries updates_;
  StageSeries refinement_;
  StageSeries frames_;
};

}  // namespace hdeform::cli

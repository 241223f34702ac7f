#include "gui/frame_statistics.h"

#include <algorithm>

#include "hdeform/stopwatch.h"

namespace hdeform::cli {
namespace {

constexpr std::size_t kSubmittedKept = 64;
constexpr std::size_t kIntervalsKept = 600;
constexpr std::size_t kLatenciesKept = 4000;
constexpr std::size_t kUpdatesKept = 100;
constexpr std::size_t kRecentUpdates = 20;

template <class T>
void keep_last(std::deque<T>& values, std::size_t count) {
  while (values.size() > count) values.pop_front();
}

}  // namespace

void FrameStatistics::note_request(std::uint64_t request, std::span<const Clock::time_point> events) {
  for (const auto& event : events) waiting_inputs_.emplace_back(request, event);
  keep_last(waiting_inputs_, kLatenciesKept);
}

void FrameStatistics::note_submitted(std::uint64_t frame, std::uint64_t shown_request, bool after_idle, Clock::time_point now) {
  submitted_.push_back({frame, shown_request, after_idle});
  keep_last(submitted_, kSubmittedKept);
  submit_times_.push_back(now);
  while (!submit_times_.empty() && now - submit_times_.front() > std::chrono::seconds(1)) submit_times_.pop_front();
}

void FrameStatistics::note_finished(std::uint64_t frame, Clock::time_point time) {
  std::uint64_t shown = 0;
  bool after_idle = true;
  for (const auto& record : submitted_) {
    if (record.frame != frame) continue;
    shown = record.shown_request;
    after_idle = record.after_idle;
  }
  if (previous_finish_ != Clock::time_point{} && !after_idle) {
    intervals_.push_back(milliseconds_between(previous_finish_, time));
    keep_last(intervals_, kIntervalsKept);
    if (recording_) recorded_intervals_.push_back(intervals_.back());
  }
  previous_finish_ = time;
  while (!waiting_inputs_.empty() && waiting_inputs_.front().first <= shown) {
    latencies_.push_back(milliseconds_between(waiting_inputs_.front().second, time));
    keep_last(latencies_, kLatenciesKept);
    if (recording_) recorded_latencies_.push_back(latencies_.back());
    waiting_inputs_.pop_front();
  }
}

void FrameStatistics::note_update(double milliseconds) {
  updates_.push_back(milliseconds);
  keep_last(updates_, kUpdatesKept);
}

std::size_t FrameStatistics::frames_per_second(Clock::time_point now) const {
  return static_cast<std::size_t>(std::count_if(submit_times_.begin(), submit_times_.end(), [&](Clock::time_point t) { return now - t <= std::chrono::seconds(1); }));
}

double FrameStatistics::recent_update_ms(double fallback) const {
  if (updates_.empty()) return fallback;
  std::vector<double> recent(updates_.end() - static_cast<std::ptrdiff_t>(std::min(updates_.size(), kRecentUpdates)), updates_.end());
  std::nth_element(recent.begin(), recent.begin() + static_cast<std::ptrdiff_t>(recent.size() / 2), recent.end());
  return recent[recent.size() / 2];
}

void FrameStatistics::restart() {
  intervals_.clear();
  latencies_.clear();
  waiting_inputs_.clear();
  previous_finish_ = {};
  recording_ = true;
  recorded_intervals_.clear();
  recorded_latencies_.clear();
}

}  // namespace hdeform::cli

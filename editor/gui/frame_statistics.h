#pragma once
// The live figures of the editor's frames, free of any window: frame intervals, frames per
// second, input-to-screen latency and the recent update time (which sizes the latch pacing's
// wait). The frame loop tells it what it submitted, what finished and when, and which inputs
// each solve request answers.
#include <chrono>
#include <cstdint>
#include <deque>
#include <span>
#include <utility>
#include <vector>

namespace hdeform::cli {

class FrameStatistics {
 public:
  using Clock = std::chrono::steady_clock;

  // A solve request (numbers grow) that answers inputs made at `events`.
  void note_request(std::uint64_t request, std::span<const Clock::time_point> events);
  // A frame submitted at `now`, showing the solve `shown_request` (0: none yet); `after_idle`
  // when the loop had waited for input before it (its interval is not a frame time).
  void note_submitted(std::uint64_t frame, std::uint64_t shown_request, bool after_idle, Clock::time_point now);
  // A submitted frame the device finished at `time`: its interval, and every input answered by
  // its solve or an earlier one is on screen now.
  void note_finished(std::uint64_t frame, Clock::time_point time);
  // A finished update's time.
  void note_update(double milliseconds);

  // The last few hundred of each, oldest first (the live figures).
  std::vector<double> frame_intervals() const { return {intervals_.begin(), intervals_.end()}; }
  std::vector<double> latencies() const { return {latencies_.begin(), latencies_.end()}; }
  // Every one since restart(), oldest first (a benchmark's whole run, however long).
  const std::vector<double>& recorded_frame_intervals() const { return recorded_intervals_; }
  const std::vector<double>& recorded_latencies() const { return recorded_latencies_; }
  // Frames submitted in the second before `now`.
  std::size_t frames_per_second(Clock::time_point now) const;
  // The median of the last 20 update times, or `fallback` before any.
  double recent_update_ms(double fallback) const;

  // Forgets the frame and latency figures and records every one from now on (the drag
  // benchmark starts clean, and reports its whole run).
  void restart();

 private:
  struct Submitted {
    std::uint64_t frame;
    std::uint64_t shown_request;
    bool after_idle;
  };
  std::deque<Submitted> submitted_;
  std::deque<Clock::time_point> submit_times_;
  std::deque<double> intervals_;
  Clock::time_point previous_finish_{};
  std::deque<std::pair<std::uint64_t, Clock::time_point>> waiting_inputs_;
  std::deque<double> latencies_;
  std::deque<double> updates_;
  bool recording_ = false;
  std::vector<double> recorded_intervals_;
  std::vector<double> recorded_latencies_;
};

}  // namespace hdeform::cli

#pragma once
// The drag benchmark's hand: timestamped pointer moves at 100 Hz from a thread of its own,
// independent of the frames, taken by the frame loop whenever it gets to them (as a mouse's
// are), and the pose they stand for: back and forth between rest and a target every 2 s.
#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "hdeform/handle_transform.h"

namespace hdeform::cli {

class SyntheticDrag {
 public:
  using Clock = std::chrono::steady_clock;

  // Starts the moves; `wake` is called after each (to wake a loop that waits for events).
  explicit SyntheticDrag(std::function<void()> wake);
  ~SyntheticDrag();  // stops them
  SyntheticDrag(const SyntheticDrag&) = delete;
  SyntheticDrag& operator=(const SyntheticDrag&) = delete;

  Clock::time_point started() const { return started_; }
  // The moves made since the last call, oldest first.
  std::vector<Clock::time_point> take();
  void stop();

  // The pose at `seconds` into the drag: `target` blended from rest and back every 2 s.
  static HandleTransform pose_at(const HandleTransform& target, double seconds);

 private:
  Clock::time_point started_ = Clock::now();
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;
  std::vector<Clock::time_point> moves_;
  std::thread thread_;
};

}  // namespace hdeform::cli

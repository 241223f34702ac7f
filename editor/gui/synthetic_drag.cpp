#include "gui/synthetic_drag.h"

#include <cmath>
#include <numbers>

namespace hdeform::cli {

SyntheticDrag::SyntheticDrag(std::function<void()> wake) {
  thread_ = std::thread([this, wake = std::move(wake)] {
    for (long k = 1; !stopping_; ++k) {
      {
        std::lock_guard lock(mutex_);
        moves_.push_back(Clock::now());
      }
      if (wake) wake();
      std::this_thread::sleep_until(started_ + std::chrono::milliseconds(10) * k);
    }
  });
}

SyntheticDrag::~SyntheticDrag() { stop(); }

void SyntheticDrag::stop() {
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
}

std::vector<SyntheticDrag::Clock::time_point> SyntheticDrag::take() {
  std::vector<Clock::time_point> moves;
  std::lock_guard lock(mutex_);
  moves.swap(moves_);
  return moves;
}

HandleTransform SyntheticDrag::pose_at(const HandleTransform& target, double seconds) {
  return target.at_fraction(0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * seconds / 2.0));
}

}  // namespace hdeform::cli

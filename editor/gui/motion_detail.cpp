#include "gui/motion_detail.h"

#include <algorithm>

namespace hdeform::cli {

std::optional<MotionDetail::Clock::duration> MotionDetail::until_rest(Clock::time_point now) const {
  if (!enabled_ || !last_motion_) return std::nullopt;
  return std::max(Clock::duration::zero(), *last_motion_ + rest_ - now);
}

}  // namespace hdeform::cli

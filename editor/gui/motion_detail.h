#pragma once
// When the editor draws a large mesh's proxy (engine/proxy_mesh.h) instead of the mesh: while it
// moves, on a CPU device, where a frame of every triangle takes longer than a drag can wait
// (buddha-206k on lavapipe: 27 ms a frame, 73-79 ms from input to screen). Moving means a drag
// input or a new solve shown within the last `rest`; once that long has passed without either,
// or once the final shape is known to be shown (come_to_rest), the next frame draws the whole
// mesh again. No window needed: times are given.
#include <chrono>
#include <optional>

namespace hdeform::cli {

class MotionDetail {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::milliseconds kRest{250};

  // Off (a GPU, --proxy off, or no proxy for this mesh): never the proxy.
  void enable(bool on) { enabled_ = on; }
  bool enabled() const { return enabled_; }

  // The mesh moved: a drag input, a new solve on screen, the view turned.
  void note_motion(Clock::time_point now) { last_motion_ = now; }
  // Whether a frame drawn at `now` shows the proxy.
  bool proxy(Clock::time_point now) const { return enabled_ && last_motion_ && now - *last_motion_ < rest_; }
  // How long until the whole mesh is due (the event loop wakes for it); nullopt when no proxy
  // frame is waiting to be replaced.
  std::optional<Clock::duration> until_rest(Clock::time_point now) const;
  // The mesh stopped: its final shape is on screen (nothing more will come, no input moves it).
  // The next frame draws it whole at once, without waiting out the rest.
  void come_to_rest() { last_motion_.reset(); }
  // Called after a frame: one drawn in full means nothing more is due.
  void note_drawn(bool proxy_drawn) {
    if (!proxy_drawn) last_motion_.reset();
  }

  explicit MotionDetail(std::chrono::milliseconds rest = kRest) : rest_(rest) {}

 private:
  bool enabled_ = false;
  std::chrono::milliseconds rest_;
  std::optional<Clock::time_point> last_motion_;
};

}  // namespace hdeform::cli

#pragma once
// When the editor draws a large mesh's proxy (engine/proxy_mesh.h) instead of the mesh: while it
// moves, on a CPU device, where a frame of every triangle takes longer than a drag can wait
// (buddha-206k on lavapipe: 27 ms a frame, 73-79 ms from input to screen). Moving means a drag
// input or a new solve shown within the last `rest`; once that long has passed without either,
// the next frame draws the whole mesh again, and at once when the motion was the solver's and its
// final shape is shown (note_frame). No window needed: times are given.
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

  // What moved the mesh in a frame: the user (a drag, a stroke, the view turned) or the solver.
  enum class Motion { None, Input, Solve };
  // The mesh moved.
  void note_motion(Clock::time_point now, Motion cause = Motion::Input) {
    last_motion_ = now;
    last_cause_ = cause;
  }
  // A frame's motion: noted, except that the solver's final shape (`settled()`: nothing more will
  // come) ends the rest instead, when it is a new solve or the rest waits out solves. Not after
  // the user's own motion, which may go on in a moment (a wheel's steps), while a whole picture of
  // a scan takes several frames' work. Returns whether the frame counts as moving. `settled` is
  // called only when it matters.
  template <class Settled>
  bool note_frame(Clock::time_point now, Motion motion, Settled&& settled) {
    if (motion == Motion::Input) {
      note_motion(now, motion);
      return true;
    }
    const bool waiting_out_solves = last_motion_.has_value() && last_cause_ == Motion::Solve;
    if (enabled_ && (motion == Motion::Solve || waiting_out_solves) && settled()) {
      come_to_rest();
      return false;
    }
    if (motion == Motion::None) return false;
    note_motion(now, motion);
    return true;
  }
  // Whether a frame drawn at `now` shows the proxy.
  bool proxy(Clock::time_point now) const { return enabled_ && last_motion_ && now - *last_motion_ < rest_; }
  // How long until the whole mesh is due (the event loop wakes for it); nullopt when no proxy
  // frame is waiting to be replaced.
  std::optional<Clock::duration> until_rest(Clock::time_point now) const;
  // Called after a frame: one drawn in full means nothing more is due.
  void note_drawn(bool proxy_drawn) {
    if (!proxy_drawn) last_motion_.reset();
  }

  explicit MotionDetail(std::chrono::milliseconds rest = kRest) : rest_(rest) {}

 private:
  bool enabled_ = false;
  std::chrono::milliseconds rest_;
  std::optional<Clock::time_point> last_motion_;
  // The mesh stopped: the next frame draws it whole, nothing due.
  void come_to_rest() { last_motion_.reset(); }
  Motion last_cause_ = Motion::Input;
};

}  // namespace hdeform::cli

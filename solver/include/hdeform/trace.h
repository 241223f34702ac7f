#pragma once
/// @file
/// A timeline of where the time goes, for a person to look at: complete events (a name, a start
/// and a duration on the thread that ran them), counters and instants, written in the Chrome
/// trace-event format (JSON), which Perfetto and chrome://tracing open.
///
/// Off by default. Instrumented code asks enabled() (one relaxed atomic load) and does nothing
/// else while tracing is off. On, each thread appends to a buffer of its own, sized when the
/// thread records its first event: no lock and no allocation per event. A full buffer drops
/// further events and counts them (the file says how many).
///
/// Names and categories must outlive the recording (string literals): only the pointers are kept.
#include <atomic>
#include <cstdint>
#include <filesystem>

namespace hdeform::trace {

namespace detail {
extern std::atomic<bool> enabled;
std::int64_t now_ns();  ///< steady clock, nanoseconds
void complete(const char* name, const char* category, std::int64_t begin_ns, std::int64_t end_ns, std::int64_t arg);
}  // namespace detail

/// Whether a recording is on (one relaxed atomic load).
inline bool enabled() { return detail::enabled.load(std::memory_order_relaxed); }

/// Starts a recording (discarding any earlier one); each thread keeps up to `events_per_thread`.
void start(std::size_t events_per_thread = std::size_t{1} << 20);
/// Stops recording; what was recorded stays until write() or the next start(), and resume()
/// goes on adding to it.
void stop();
/// Goes on recording after stop(), adding to what was recorded.
void resume();
/// Writes what was recorded, atomically (InputError naming the file when it cannot). Safe while
/// other threads still record: it takes the events published so far.
void write(const std::filesystem::path& path);

/// Calls into the recorder since the program started (a test checks that tracing off makes none)
/// and the events held.
std::uint64_t recorder_calls();
/// The events recorded so far.
std::size_t recorded_events();

/// A complete event over this object's lifetime, on the calling thread; `arg` (if not negative)
/// appears as args.n (a subtree, an iteration, a request number).
class Scope {
 public:
  /// Starts the event (when recording); it ends when the object is destroyed.
  Scope(const char* name, const char* category, std::int64_t arg = -1) {
    if (enabled()) {
      name_ = name;
      category_ = category;
      arg_ = arg;
      begin_ns_ = detail::now_ns();
    }
  }
  ~Scope() {
    if (name_ != nullptr) detail::complete(name_, category_, begin_ns_, detail::now_ns(), arg_);
  }
  Scope(const Scope&) = delete;
  Scope& operator=(const Scope&) = delete;

 private:
  const char* name_ = nullptr;
  const char* category_ = nullptr;
  std::int64_t arg_ = -1;
  std::int64_t begin_ns_ = 0;
};

/// A complete event timed elsewhere (the device's time for a frame), on the calling thread unless
/// `track` names a track of its own ("device").
void complete(const char* name, const char* category, std::int64_t begin_ns, std::int64_t end_ns, const char* track = nullptr);
/// A value over time (memory, requests waiting), and a moment (an input event, a presentation).
void counter(const char* name, double value);
/// Records a moment on the calling thread.
void instant(const char* name, const char* category);
/// Names the calling thread in the timeline ("solver", "presenter").
void name_thread(const char* name);

/// The recorder's clock: steady, nanoseconds.
inline std::int64_t now_ns() { return detail::now_ns(); }

}  // namespace hdeform::trace

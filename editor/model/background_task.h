#pragma once
// One piece of work on a thread of its own (reading a mesh, factoring for a new selection,
// transferring a sequence) whose outcome the editor picks up when it is done, so that no frame
// ever waits for it.
#include <atomic>
#include <chrono>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include "hdeform/stopwatch.h"

namespace hdeform::cli {

// Work whose outcome nobody wants any more, still running. Abandoning work hands its thread here
// instead of waiting for it: a stage of a set-up cannot stop partway (the 3.3M Buddha's order of
// every vertex takes 15 s), and Open or Quit must not wait for it.
namespace left_running {
// Takes `thread`, which sets `*ended` as its last act.
void adopt(std::thread thread, std::shared_ptr<const std::atomic<bool>> ended);
// How many adopted threads have not ended yet.
std::size_t count();
// Joins every adopted thread (the process's static destructors do it too, so that none outlives
// what it uses).
void join_all();
}  // namespace left_running

template <class Result>
class BackgroundTask {
 public:
  struct Outcome {
    std::optional<Result> result;
    std::string error;             // the exception's message, when the work threw
    std::exception_ptr exception;  // and the exception itself (to tell out of memory apart)
  };

  BackgroundTask() = default;
  ~BackgroundTask() { abandon(); }
  BackgroundTask(const BackgroundTask&) = delete;
  BackgroundTask& operator=(const BackgroundTask&) = delete;

  // Starts `work` (it returns a Result or throws), described by `what` for the progress overlay;
  // `finished` runs on the worker when it ends (to wake a loop waiting for events), unless the
  // work was abandoned first. Abandons any earlier work not taken.
  template <class Work>
  void start(std::string what, Work work, std::function<void()> finished = {}) {
    abandon();
    what_ = std::move(what);
    started_ = SteadyClock::now();
    pending_ = true;
    state_ = std::make_shared<State>();
    state_->finished = std::move(finished);
    // The worker holds the state, not this task: abandoned, it runs on after the task is gone.
    thread_ = std::thread([state = state_, work = std::move(work)]() mutable {
      Outcome outcome;
      try {
        outcome.result.emplace(work());
      } catch (const std::exception& error) {
        outcome.error = error.what();
        outcome.exception = std::current_exception();
      } catch (...) {
        outcome.error = "unknown error";
        outcome.exception = std::current_exception();
      }
      {
        std::lock_guard lock(state->mutex);
        if (!state->abandoned) state->outcome = std::move(outcome);
        state->done = true;
        // Under the lock, so that once abandon() returns the callback never runs (it may wake a
        // window system that is gone by then).
        if (!state->abandoned && state->finished) state->finished();
      }
      // An abandoned outcome (a whole document, at times) goes here, on this thread, and so do the
      // work's captures, as the thread ends.
      outcome = Outcome{};
      state->ended = true;
    });
  }

  // Started and not yet taken.
  bool running() const { return pending_; }
  bool done() const { return state_ && state_->done.load(); }
  const std::string& what() const { return what_; }
  double seconds() const { return seconds_since(started_); }

  // Blocks until the work is done (its outcome stays to be taken).
  void wait() {
    if (thread_.joinable()) thread_.join();
  }

  // After done() (or wait()): hands over the outcome.
  Outcome take() {
    wait();
    pending_ = false;
    Outcome outcome;
    if (state_) {
      std::lock_guard lock(state_->mutex);
      outcome = std::exchange(state_->outcome, Outcome{});
    }
    state_.reset();
    return outcome;
  }

  // Drops the outcome of any work not taken, without waiting for work still running: its thread
  // runs on to its end (left_running), and its `finished` is not called.
  void abandon() {
    if (!pending_) return;
    pending_ = false;
    {
      std::lock_guard lock(state_->mutex);
      state_->abandoned = true;
      state_->outcome = Outcome{};
    }
    if (thread_.joinable()) {
      if (state_->ended.load()) thread_.join();
      else left_running::adopt(std::move(thread_), std::shared_ptr<const std::atomic<bool>>(state_, &state_->ended));
    }
    state_.reset();
  }

  // Waits for work still running and drops its outcome: for work that must end before what
  // follows (a save being written).
  void finish() {
    if (!pending_) return;
    take();
  }

 private:
  struct State {
    std::mutex mutex;
    Outcome outcome;  // with mutex
    bool abandoned = false;  // with mutex
    std::function<void()> finished;
    std::atomic<bool> done{false};   // the outcome is in
    std::atomic<bool> ended{false};  // the thread has nothing left to do
  };
  std::thread thread_;
  std::shared_ptr<State> state_;
  bool pending_ = false;  // started, outcome not taken
  std::string what_;
  SteadyClock::time_point started_{};
};

}  // namespace hdeform::cli

#pragma once
// One piece of work on a thread of its own (reading a mesh, factoring for a new selection,
// transferring a sequence) whose outcome the editor picks up when it is done, so that no frame
// ever waits for it.
#include <atomic>
#include <chrono>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include "hdeform/stopwatch.h"

namespace hdeform::cli {

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
  // `finished` runs on the worker when it ends (to wake a loop waiting for events). Only while
  // no earlier work is still to be taken.
  template <class Work>
  void start(std::string what, Work work, std::function<void()> finished = {}) {
    abandon();
    what_ = std::move(what);
    started_ = SteadyClock::now();
    done_ = false;
    pending_ = true;
    thread_ = std::thread([this, work = std::move(work), finished = std::move(finished)]() mutable {
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
        std::lock_guard lock(mutex_);
        outcome_ = std::move(outcome);
      }
      done_ = true;
      if (finished) finished();
    });
  }

  // Started and not yet taken.
  bool running() const { return pending_; }
  bool done() const { return done_.load(); }
  const std::string& what() const { return what_; }
  double seconds() const { return seconds_since(started_); }

  // Blocks until the work is done (its outcome stays to be taken).
  void wait() {
    if (thread_.joinable()) thread_.join();
  }

  // After done() (or wait()): hands over the outcome.
  Outcome take() {
    wait();
    done_ = false;
    pending_ = false;
    std::lock_guard lock(mutex_);
    return std::exchange(outcome_, Outcome{});
  }

  // Waits for any work still running and drops its outcome.
  void abandon() {
    if (!pending_) return;
    take();
  }

 private:
  std::thread thread_;
  bool pending_ = false;  // started, outcome not taken
  std::atomic<bool> done_{false};
  std::mutex mutex_;
  Outcome outcome_;  // with mutex_
  std::string what_;
  SteadyClock::time_point started_{};
};

}  // namespace hdeform::cli

#include "hdeform/update_pipeline.h"

#include <chrono>

#include "hdeform/trace.h"
#include "hdeform/stopwatch.h"

namespace hdeform {

UpdatePipeline::UpdatePipeline(Deformer& deformer, Publish publish, Fail fail)
    : deformer_(deformer), publish_(std::move(publish)), fail_(std::move(fail)) {
  pending_.reserve(deformer.handle_count());
  current_.reserve(deformer.handle_count());
  // The copy of the rest positions is the thread's first work, not its creator's: at 13 million
  // triangles it is 158 MB of new pages, which held the editor's window 0.5 s when the set-up was
  // installed. Until it is made the pipeline counts as busy (busy_ starts true).
  thread_ = std::thread([this] {
    trace::name_thread("solver");
    {
      const trace::Scope traced("rest positions copied", "update");
      positions_ = deformer_.rest().positions;
    }
    run();
  });
}

UpdatePipeline::~UpdatePipeline() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    has_pending_ = false;
  }
  wake_.notify_all();
  thread_.join();
}

std::uint64_t UpdatePipeline::submit(std::span<const HandleTransform> transforms, std::shared_ptr<const std::vector<int>> only_vertices) {
  std::uint64_t request = 0;
  {
    std::lock_guard lock(mutex_);
    pending_.assign(transforms.begin(), transforms.end());
    pending_only_ = std::move(only_vertices);
    if (has_pending_) ++superseded_;
    has_pending_ = true;
    trace::counter("requests waiting", 1.0);
    last_submit_ = std::chrono::steady_clock::now();
    refined_out_ = !refine_;
    request = pending_request_ = ++submitted_;
  }
  wake_.notify_one();
  return request;
}

void UpdatePipeline::run() {
  for (;;) {
    std::uint64_t request = 0;
    bool update = false;
    {
      std::unique_lock lock(mutex_);
      busy_ = false;
      for (;;) {
        if (stopping_) return;
        if (has_pending_) break;
        if (wants_refinement() || !whole_) {
          // Refinement (and the rebuild of a partial answer) waits until the input has rested
          // for the delay (a new request ends the wait).
          const auto ready = last_submit_ + refinement_delay_;
          if (std::chrono::steady_clock::now() >= ready) break;
          wake_.wait_until(lock, ready);
          continue;
        }
        idle_.notify_all();
        wake_.wait(lock, [&] { return has_work() || stopping_; });
      }
      busy_ = true;
      if (has_pending_) {
        std::swap(current_, pending_);
        current_only_ = std::move(pending_only_);
        has_pending_ = false;
        trace::counter("requests waiting", 0.0);
        request = pending_request_;
        answered_request_ = request;
        update = true;
      } else {
        request = answered_request_;
      }
    }
    const bool refining = !update && whole_;  // (whole_ is this thread's to write)
    try {
      const auto start = std::chrono::steady_clock::now();
      RefinementStatus status;
      bool converged = true;
      bool whole = true, completion = false;
      if (update) {
        const trace::Scope traced("request", "pipeline", static_cast<std::int64_t>(request));
        // An answer for some vertices is published as that, even where the deformer wrote every
        // row (an exact solve): the whole one follows in the same way for every deformer.
        if (current_only_) {
          deformer_.deform_vertices(current_, positions_, *current_only_);
          whole = false;
        } else {
          deformer_.deform(current_, positions_);
        }
      } else if (!whole_) {
        const trace::Scope traced("the rest of the vertices", "pipeline", static_cast<std::int64_t>(request));
        deformer_.complete(positions_);
        completion = true;
      } else {
        // Written only when shown: on a base the write rebuilds the fine mesh.
        if (deformer_.refine_unwritten(positions_, 1) > 0) refined_unwritten_ = true;
        status = deformer_.refinement_status();
        converged = status.converged;
      }
      if (update || completion) refined_unwritten_ = false;
      bool publish = true;
      if (!update && !completion && !converged && status.iterations < deformer_.refinement_options().max_iterations) {
        std::lock_guard lock(mutex_);
        publish = std::chrono::steady_clock::now() - last_publication_ >= publication_interval_;
      }
      if (publish && refined_unwritten_) {
        deformer_.write_refined(positions_);
        refined_unwritten_ = false;
      }
      const double elapsed = milliseconds_since(start);
      const auto now = std::chrono::steady_clock::now();
      if (publish) {
        const trace::Scope traced("publish", "pipeline");
        publish_(Result{positions_, request, elapsed, status, !whole, completion});
        last_publication_ = now;
      }
      std::lock_guard lock(mutex_);
      whole_ = whole;
      if (update) {
        ++finished_;
        has_result_ = true;
        refined_out_ = !refine_;
      } else if (completion) {
        // The same answer, whole: the refinement (when on) starts from it.
      } else {
        refined_out_ = converged || status.iterations >= deformer_.refinement_options().max_iterations;
      }
    } catch (...) {
      const std::exception_ptr error = std::current_exception();
      {
        std::lock_guard lock(mutex_);
        error_ = error;
        refined_out_ = true;
        whole_ = true;  // nothing more to try for this answer (the error says why)
      }
      // Before the loop's next turn says the pipeline is idle: whoever waits for it finds the
      // failure recorded.
      if (fail_) fail_(Failure{request, error, refining});
    }
  }
}

bool UpdatePipeline::wants_refinement() const { return refine_ && !refined_out_ && has_result_; }
bool UpdatePipeline::has_work() const { return has_pending_ || !whole_ || wants_refinement(); }

void UpdatePipeline::set_refinement_delay(std::chrono::milliseconds delay) {
  {
    std::lock_guard lock(mutex_);
    refinement_delay_ = delay;
  }
  wake_.notify_one();
}

void UpdatePipeline::set_refinement_publication_interval(std::chrono::milliseconds interval) {
  std::lock_guard lock(mutex_);
  publication_interval_ = interval;
}

void UpdatePipeline::wait_idle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [this] { return !busy_ && !has_work(); });
}

Eigen::MatrixXd UpdatePipeline::settled_positions() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [this] { return !busy_ && !has_work(); });
  // The thread only takes work under the lock: while it is held, positions_ stays as published.
  return positions_;
}

void UpdatePipeline::set_refinement(bool on) {
  {
    std::lock_guard lock(mutex_);
    if (refine_ == on) return;
    refine_ = on;
    refined_out_ = !on;
  }
  wake_.notify_one();
  idle_.notify_all();  // turned off, there may be nothing left to wait for
}

bool UpdatePipeline::refinement() const {
  std::lock_guard lock(mutex_);
  return refine_;
}

std::uint64_t UpdatePipeline::finished_updates() const {
  std::lock_guard lock(mutex_);
  return finished_;
}

std::uint64_t UpdatePipeline::superseded_requests() const {
  std::lock_guard lock(mutex_);
  return superseded_;
}

std::exception_ptr UpdatePipeline::last_error() const {
  std::lock_guard lock(mutex_);
  return error_;
}

}  // namespace hdeform

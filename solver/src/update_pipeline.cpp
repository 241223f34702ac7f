#include "hdeform/update_pipeline.h"

#include <chrono>

namespace hdeform {

UpdatePipeline::UpdatePipeline(Deformer& deformer, Publish publish) : deformer_(deformer), publish_(std::move(publish)) {
  pending_.reserve(deformer.handle_count());
  current_.reserve(deformer.handle_count());
  positions_ = deformer.rest().positions;
  thread_ = std::thread([this] { run(); });
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

std::uint64_t UpdatePipeline::submit(std::span<const HandleTransform> transforms) {
  std::uint64_t request = 0;
  {
    std::lock_guard lock(mutex_);
    pending_.assign(transforms.begin(), transforms.end());
    if (has_pending_) ++superseded_;
    has_pending_ = true;
    running_ = true;
    request = pending_request_ = ++submitted_;
  }
  wake_.notify_one();
  return request;
}

void UpdatePipeline::run() {
  for (;;) {
    std::uint64_t request = 0;
    {
      std::unique_lock lock(mutex_);
      if (!has_pending_) {
        running_ = false;
        idle_.notify_all();
        wake_.wait(lock, [this] { return has_pending_ || stopping_; });
        if (stopping_) return;
      }
      std::swap(current_, pending_);
      has_pending_ = false;
      request = pending_request_;
    }
    try {
      const auto start = std::chrono::steady_clock::now();
      deformer_.deform(current_, positions_);
      const double elapsed = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      publish_(Result{positions_, request, elapsed});
      std::lock_guard lock(mutex_);
      ++finished_;
    } catch (...) {
      std::lock_guard lock(mutex_);
      error_ = std::current_exception();
    }
  }
}

void UpdatePipeline::wait_idle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [this] { return !running_; });
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

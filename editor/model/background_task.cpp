#include "background_task.h"

#include <algorithm>
#include <vector>

namespace hdeform::cli::left_running {
namespace {

struct Adopted {
  std::thread thread;
  std::shared_ptr<const std::atomic<bool>> ended;
};

class Registry {
 public:
  ~Registry() { join_all(); }

  void adopt(Adopted adopted) {
    std::lock_guard lock(mutex_);
    join_ended();
    threads_.push_back(std::move(adopted));
  }
  std::size_t count() {
    std::lock_guard lock(mutex_);
    join_ended();
    return threads_.size();
  }
  void join_all() {
    std::vector<Adopted> threads;
    {
      std::lock_guard lock(mutex_);
      threads.swap(threads_);
    }
    for (Adopted& adopted : threads) adopted.thread.join();
  }

 private:
  // With mutex_. An ended thread is past its work (only its captures are still to go).
  void join_ended() {
    const auto ended = std::partition(threads_.begin(), threads_.end(), [](const Adopted& adopted) { return !adopted.ended->load(); });
    for (auto it = ended; it != threads_.end(); ++it) it->thread.join();
    threads_.erase(ended, threads_.end());
  }

  std::mutex mutex_;
  std::vector<Adopted> threads_;
};

Registry& registry() {
  static Registry instance;
  return instance;
}

}  // namespace

void adopt(std::thread thread, std::shared_ptr<const std::atomic<bool>> ended) { registry().adopt({std::move(thread), std::move(ended)}); }

std::size_t count() { return registry().count(); }

void join_all() { registry().join_all(); }

}  // namespace hdeform::cli::left_running

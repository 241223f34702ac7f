#include "termination_signals.h"

#include <dlfcn.h>
#include <pthread.h>
#include <signal.h>

#include <array>
#include <atomic>
#include <csignal>
#include <mutex>
#include <thread>

namespace hdeform::cli {
namespace {

constexpr std::array<int, 3> kSignals{SIGTERM, SIGINT, SIGHUP};
// The claim and its wake function: the watching thread holds the mutex while it calls `wake`, so
// that once release_termination_signals() returns, no wake runs or will run (the editor's wakes
// its window system, which it shuts down after the release).
std::mutex claim_mutex;
bool claimed = false;               // with claim_mutex
void (*wake_claimant)() = nullptr;  // with claim_mutex
std::atomic<int> received{0};

sigset_t termination_set() {
  sigset_t set;
  sigemptyset(&set);
  for (const int signal : kSignals) sigaddset(&set, signal);
  return set;
}

// What the signal would have done unblocked: its default action (the process ends), whatever
// handler another library put in place meanwhile.
[[noreturn]] void end_as_by_default(int signal) {
  struct sigaction default_action {};
  default_action.sa_handler = SIG_DFL;
  sigemptyset(&default_action.sa_mask);
  sigaction(signal, &default_action, nullptr);
  sigset_t just_this;
  sigemptyset(&just_this);
  sigaddset(&just_this, signal);
  pthread_sigmask(SIG_UNBLOCK, &just_this, nullptr);
  pthread_kill(pthread_self(), signal);
  std::_Exit(128 + signal);  // not reached
}

void watch(sigset_t set) {
  for (;;) {
    int signal = 0;
    if (sigwait(&set, &signal) != 0) continue;
    const std::lock_guard lock(claim_mutex);
    if (!claimed) end_as_by_default(signal);
    int none = 0;
    received.compare_exchange_strong(none, signal);
    if (wake_claimant != nullptr) wake_claimant();
  }
}

}  // namespace

void watch_termination_signals() {
  static std::once_flag once;
  std::call_once(once, [] {
    // OpenBLAS (CHOLMOD's BLAS) starts its threads as it is loaded, before main(), with no signal
    // blocked: one of them would take the signal. Its pool is stopped here and starts again at
    // its next use, from a thread that blocks them.
    if (auto* stop_pool = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "blas_thread_shutdown_"))) stop_pool();
    const sigset_t set = termination_set();
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    std::thread(watch, set).detach();
  });
}

void claim_termination_signals(void (*wake)()) {
  watch_termination_signals();  // where main() did not
  const std::lock_guard lock(claim_mutex);
  received = 0;
  wake_claimant = wake;
  claimed = true;
}

void release_termination_signals() {
  const std::lock_guard lock(claim_mutex);
  claimed = false;
  wake_claimant = nullptr;
}

int termination_signal() { return received.load(); }

}  // namespace hdeform::cli

// The hdeform executable's termination signals (commands/termination_signals.h): blocked in every
// thread and taken by one of their own, so that a handler another library installs for a while
// (METIS installs one for SIGTERM during each nested dissection, which jumps back into METIS on
// the thread that runs it) never sees them. Each case runs in a process of its own (a death test).
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <thread>

#include "commands/termination_signals.h"

namespace hdeform {
namespace {

using namespace std::chrono_literals;

// What METIS does while it runs: its own handler, for the whole process.
extern "C" void foreign_handler(int) { std::_Exit(42); }

void sleep_then_exit(int code) {
  std::this_thread::sleep_for(10s);
  std::_Exit(code);
}

TEST(TerminationSignals, ASignalEndsTheProcessAsByDefaultWhateverHandlerIsInstalled) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        cli::watch_termination_signals();
        std::signal(SIGTERM, foreign_handler);
        std::thread([] { kill(getpid(), SIGTERM); }).join();  // from a thread that blocks it too
        sleep_then_exit(0);
      },
      ::testing::KilledBySignal(SIGTERM), "");
  // Without the watch, the installed handler takes it: what made the editor crash.
  EXPECT_EXIT(
      {
        std::signal(SIGTERM, foreign_handler);
        kill(getpid(), SIGTERM);
        sleep_then_exit(0);
      },
      ::testing::ExitedWithCode(42), "");
}

std::atomic<int> wakes{0};

TEST(TerminationSignals, AClaimedSignalIsRecordedAndWakesTheClaimant) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        cli::watch_termination_signals();
        cli::claim_termination_signals([] { ++wakes; });
        std::signal(SIGTERM, foreign_handler);
        kill(getpid(), SIGHUP);
        kill(getpid(), SIGTERM);
        const auto deadline = std::chrono::steady_clock::now() + 10s;
        while (wakes < 2 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
        // Both woke the claimant; the first is the one recorded; the process lives on.
        std::_Exit(wakes == 2 && cli::termination_signal() == SIGHUP ? 7 : 1);
      },
      ::testing::ExitedWithCode(7), "");
  EXPECT_EXIT(
      {
        cli::watch_termination_signals();
        cli::claim_termination_signals([] {});
        cli::release_termination_signals();
        kill(getpid(), SIGINT);  // released: its usual effect again
        sleep_then_exit(0);
      },
      ::testing::KilledBySignal(SIGINT), "");
}

}  // namespace
}  // namespace hdeform

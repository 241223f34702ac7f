// Work on a thread of its own, as the editor runs it: abandoning it never waits.
#include <atomic>
#include <chrono>
#include <memory>
#include <stdexcept>
#include <thread>
#include <utility>

#include "model/background_task.h"
#include "model/document.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

using namespace std::chrono_literals;

// Counts its destructions: an outcome let go of must still be destroyed, once.
struct Counted {
  explicit Counted(std::atomic<int>* counter) : destroyed(counter) {}
  Counted(Counted&& other) noexcept : destroyed(std::exchange(other.destroyed, nullptr)) {}
  Counted& operator=(Counted&& other) noexcept {
    count();
    destroyed = std::exchange(other.destroyed, nullptr);
    return *this;
  }
  ~Counted() { count(); }
  void count() {
    if (destroyed != nullptr) ++*destroyed;
  }
  std::atomic<int>* destroyed;
};

TEST(BackgroundTask, AbandoningReturnsWhileTheWorkRunsAndItsOutcomeAndCallbackAreDropped) {
  std::atomic<bool> released{false};
  std::atomic<bool> released_in_time{false};
  std::atomic<int> destroyed{0};
  std::atomic<int> finished{0};
  {
    cli::BackgroundTask<Counted> task;
    task.start("waits to be released", [&] {
      // An abandon() that waited for the work would hold the release back past this deadline.
      const auto deadline = std::chrono::steady_clock::now() + 20s;
      while (!released.load() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
      released_in_time = released.load();
      return Counted(&destroyed);
    }, [&] { ++finished; });
    EXPECT_TRUE(task.running());
    task.abandon();
    EXPECT_FALSE(task.running());
    EXPECT_FALSE(task.done());
    EXPECT_GE(cli::left_running::count(), 1U);
    released = true;
  }
  cli::left_running::join_all();
  EXPECT_EQ(cli::left_running::count(), 0U);
  EXPECT_TRUE(released_in_time.load());
  EXPECT_EQ(destroyed.load(), 1);
  EXPECT_EQ(finished.load(), 0);
}

TEST(BackgroundTask, TheOutcomeIsHandedOverOnceDoneAndTheCallbackRuns) {
  std::atomic<int> destroyed{0};
  std::atomic<int> finished{0};
  cli::BackgroundTask<Counted> task;
  task.start("returns at once", [&] { return Counted(&destroyed); }, [&] { ++finished; });
  task.wait();
  EXPECT_TRUE(task.done());
  EXPECT_EQ(finished.load(), 1);
  auto outcome = task.take();
  ASSERT_TRUE(outcome.result.has_value());
  EXPECT_EQ(outcome.result->destroyed, &destroyed);
  EXPECT_TRUE(outcome.error.empty());
  EXPECT_FALSE(task.running());
  EXPECT_FALSE(task.done());
  EXPECT_EQ(destroyed.load(), 0);  // the one handed over is still alive
}

TEST(BackgroundTask, AnExceptionIsTheOutcomesErrorAndFinishWaits) {
  cli::BackgroundTask<int> task;
  task.start("throws", []() -> int { throw std::runtime_error("the mesh has no triangles"); });
  task.wait();
  auto outcome = task.take();
  EXPECT_FALSE(outcome.result.has_value());
  EXPECT_EQ(outcome.error, "the mesh has no triangles");
  EXPECT_TRUE(outcome.exception != nullptr);

  std::atomic<bool> ended{false};
  task.start("sleeps", [&] {
    std::this_thread::sleep_for(50ms);
    ended = true;
    return 1;
  });
  task.finish();
  EXPECT_TRUE(ended.load());
  EXPECT_FALSE(task.running());
}

// A document closed during its set-up lets the set-up run on to its next stage without waiting
// for it, and what that set-up still reads outlives the document (AddressSanitizer and
// ThreadSanitizer would say otherwise).
TEST(BackgroundTask, ADocumentClosedDuringItsSetUpLeavesItRunningOnWhatItOwns) {
  const Shape shape = make_shape(ShapeKind::Cactus, 48);
  for (int attempt = 0; attempt < 3; ++attempt) {
    cli::Session session;
    session.mesh = "shape:cactus:48";
    auto document = std::make_unique<cli::Document>(session, shape.mesh, DeformerOptions{}, cli::Document::Publish{});
    document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
    document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
    document->poll();
    EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Building);
    document->close();
    document.reset();
  }
  cli::left_running::join_all();
  EXPECT_EQ(cli::left_running::count(), 0U);
}

}  // namespace
}  // namespace hdeform

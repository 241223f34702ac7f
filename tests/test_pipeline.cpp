#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include "hdeform/deformer.h"
#include "hdeform/shapes.h"
#include "hdeform/update_pipeline.h"
#include "test_support.h"

namespace hdeform {
namespace {

TEST(UpdatePipeline, TheNewestRequestWinsAndIsPublishedLast) {
  auto shape = make_shape(ShapeKind::Cactus, 64);
  Deformer deformer(shape.mesh, shape.demo_constraints);
  std::mutex mutex;
  std::vector<std::uint64_t> published;
  Eigen::MatrixXd last;
  UpdatePipeline pipeline(deformer, [&](const UpdatePipeline::Result& result) {
    std::lock_guard lock(mutex);
    published.push_back(result.request);
    last = result.positions;
  });
  constexpr int kRequests = 200;
  std::uint64_t final_request = 0;
  for (int k = 1; k <= kRequests; ++k) {
    const auto transform = shape.demo_transform.at_fraction(k / static_cast<double>(kRequests));
    final_request = pipeline.submit(std::span(&transform, 1));
  }
  pipeline.wait_idle();
  EXPECT_EQ(pipeline.last_error(), nullptr);
  ASSERT_FALSE(published.empty());
  EXPECT_EQ(published.back(), final_request);
  EXPECT_TRUE(std::is_sorted(published.begin(), published.end()));
  EXPECT_EQ(pipeline.finished_updates() + pipeline.superseded_requests(), static_cast<std::uint64_t>(kRequests));
  // Requests came faster than updates finish: most were coalesced away.
  EXPECT_LT(pipeline.finished_updates(), static_cast<std::uint64_t>(kRequests));

  Eigen::MatrixXd expected;
  deformer.deform(std::span(&shape.demo_transform, 1), expected);
  EXPECT_EQ(last, expected);
}

TEST(UpdatePipeline, AFailedUpdateIsReportedAndKeepsThePreviousResult) {
  auto shape = make_shape(ShapeKind::Sphere, 16);
  Deformer deformer(shape.mesh, shape.demo_constraints);
  std::atomic<int> publications{0};
  std::vector<UpdatePipeline::Failure> failures;  // the pipeline's thread writes it before wait_idle() returns
  UpdatePipeline pipeline(deformer, [&](const UpdatePipeline::Result&) { ++publications; },
                          [&](const UpdatePipeline::Failure& failure) { failures.push_back(failure); });
  pipeline.submit(std::span(&shape.demo_transform, 1));
  pipeline.wait_idle();
  EXPECT_EQ(publications.load(), 1);
  EXPECT_TRUE(failures.empty());
  const std::vector<HandleTransform> wrong_count(2);
  const std::uint64_t failed = pipeline.submit(wrong_count);  // two transforms for one handle: the update throws
  pipeline.wait_idle();
  EXPECT_NE(pipeline.last_error(), nullptr);
  EXPECT_EQ(publications.load(), 1);
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0].request, failed);
  EXPECT_FALSE(failures[0].refining);
  EXPECT_EQ(failures[0].error, pipeline.last_error());
  // The next request is answered as usual.
  pipeline.submit(std::span(&shape.demo_transform, 1));
  pipeline.wait_idle();
  EXPECT_EQ(publications.load(), 2);
  EXPECT_EQ(failures.size(), 1u);
}

// A refinement that throws (here its second iteration's publication) ends the work for its
// request, says so, and leaves the pipeline idle instead of refining for ever; the next request is
// refined as usual.
TEST(UpdatePipeline, AFailedRefinementEndsItsRequestAndTheNextIsRefinedAsUsual) {
  auto shape = make_shape(ShapeKind::Cylinder, 16);
  DeformerOptions options;
  options.prepare_refinement = true;
  Deformer deformer(shape.mesh, shape.demo_constraints, options);
  std::atomic<bool> fail_second_iteration{true};
  std::vector<int> published;  // iterations of each publication
  std::vector<bool> converged;
  std::vector<UpdatePipeline::Failure> failures;
  UpdatePipeline pipeline(
      deformer,
      [&](const UpdatePipeline::Result& result) {
        if (result.refinement.iterations == 2 && fail_second_iteration.exchange(false)) throw std::runtime_error("no room for it");
        published.push_back(result.refinement.iterations);
        converged.push_back(result.refinement.converged);
      },
      [&](const UpdatePipeline::Failure& failure) { failures.push_back(failure); });
  const HandleTransform drag = HandleTransform::from_affine((Eigen::Matrix<double, 3, 4>() << 1, 0, 0, 0.4, 0, 1, 0, 0, 0, 0, 1, -0.1).finished());
  pipeline.set_refinement(true);
  const std::uint64_t first = pipeline.submit(std::span(&drag, 1));
  pipeline.wait_idle();
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0].request, first);
  EXPECT_TRUE(failures[0].refining);
  ASSERT_NE(pipeline.last_error(), nullptr);
  EXPECT_THROW(std::rethrow_exception(pipeline.last_error()), std::runtime_error);
  EXPECT_EQ(published, (std::vector<int>{0, 1}));  // nothing after the failure
  EXPECT_EQ(pipeline.settled_positions().rows(), shape.mesh.vertex_count());  // idle: returns at once

  const HandleTransform further = drag.at_fraction(0.5);
  pipeline.submit(std::span(&further, 1));
  pipeline.wait_idle();
  EXPECT_EQ(failures.size(), 1u);
  ASSERT_GT(published.size(), 3u);
  EXPECT_EQ(published[2], 0);
  EXPECT_TRUE(converged.back());
}

// With refinement on, each request is answered by the paper's update first, then by iterations
// whose energy falls until they converge; a new request takes over after the iteration in flight.
TEST(UpdatePipeline, RefinementFollowsThePapersUpdateAndANewRequestInterruptsIt) {
  auto shape = make_shape(ShapeKind::Cylinder, 16);
  DeformerOptions options;
  options.prepare_refinement = true;
  Deformer deformer(shape.mesh, shape.demo_constraints, options);
  struct Seen {
    std::uint64_t request;
    int iterations;
    double energy;
    bool converged;
  };
  std::mutex mutex;
  std::vector<Seen> seen;
  Eigen::MatrixXd last;
  UpdatePipeline pipeline(deformer, [&](const UpdatePipeline::Result& result) {
    std::lock_guard lock(mutex);
    seen.push_back({result.request, result.refinement.iterations, result.refinement.energy, result.refinement.converged});
    last = result.positions;
  });
  const HandleTransform drag = HandleTransform::from_affine((Eigen::Matrix<double, 3, 4>() << 1, 0, 0, 0.4, 0, 1, 0, 0, 0, 0, 1, -0.1).finished());
  pipeline.set_refinement(true);
  const std::uint64_t first = pipeline.submit(std::span(&drag, 1));
  pipeline.wait_idle();  // until converged
  ASSERT_GT(seen.size(), 3u);
  EXPECT_EQ(seen.front().request, first);
  EXPECT_EQ(seen.front().iterations, 0);  // the paper's update comes first
  for (std::size_t k = 1; k < seen.size(); ++k) {
    EXPECT_EQ(seen[k].request, first);
    EXPECT_EQ(seen[k].iterations, static_cast<int>(k));
    if (k > 1) {
      EXPECT_LE(seen[k].energy, seen[k - 1].energy * (1.0 + 1e-12));
    }
  }
  EXPECT_TRUE(seen.back().converged);
  // The same as refining by hand from the same start.
  {
    Deformer alone(shape.mesh, shape.demo_constraints, options);
    Eigen::MatrixXd expected;
    alone.deform(std::span(&drag, 1), expected);
    alone.refine(expected, 1000);
    EXPECT_EQ(last, expected);
  }
  // A new request while refining: answered at once by its own update, then refined in turn.
  const std::size_t before = seen.size();
  const HandleTransform further = drag.at_fraction(0.5);
  const std::uint64_t second = pipeline.submit(std::span(&further, 1));
  pipeline.wait_idle();
  ASSERT_GT(seen.size(), before + 1);
  EXPECT_EQ(seen[before].request, second);
  EXPECT_EQ(seen[before].iterations, 0);
  EXPECT_TRUE(seen.back().converged);
  // Off: updates only.
  pipeline.set_refinement(false);
  const std::size_t off = seen.size();
  pipeline.submit(std::span(&drag, 1));
  pipeline.wait_idle();
  EXPECT_EQ(seen.size(), off + 1);
  EXPECT_EQ(seen.back().iterations, 0);
}

// Shown a few times a second (the editor on a CPU device), a settling shape skips the frames
// between: the iterations in between are not written, and the last one published is the
// refined shape itself, to the last bit.
TEST(UpdatePipeline, IterationsBetweenPublicationsAreSkippedAndTheLastIsTheRefinedShape) {
  auto shape = make_shape(ShapeKind::Cylinder, 16);
  DeformerOptions options;
  options.prepare_refinement = true;
  Deformer deformer(shape.mesh, shape.demo_constraints, options);
  std::mutex mutex;
  std::vector<int> iterations;
  Eigen::MatrixXd last;
  UpdatePipeline pipeline(deformer, [&](const UpdatePipeline::Result& result) {
    std::lock_guard lock(mutex);
    iterations.push_back(result.refinement.iterations);
    last = result.positions;
  });
  pipeline.set_refinement_publication_interval(std::chrono::hours(1));
  pipeline.set_refinement(true);
  pipeline.submit(std::span(&shape.demo_transform, 1));
  pipeline.wait_idle();
  Deformer alone(shape.mesh, shape.demo_constraints, options);
  Eigen::MatrixXd expected;
  alone.deform(std::span(&shape.demo_transform, 1), expected);
  const int needed = alone.refine(expected, 1000);
  ASSERT_GT(needed, 3);
  std::lock_guard lock(mutex);
  // The paper's update, then the converged shape: none in between within the hour.
  EXPECT_EQ(iterations, (std::vector<int>{0, needed}));
  EXPECT_EQ(last, expected);
}

TEST(UpdatePipeline, WithADelayRefinementWaitsForTheInputToRest) {
  auto shape = make_shape(ShapeKind::Cylinder, 12);
  DeformerOptions options;
  options.prepare_refinement = true;
  Deformer deformer(shape.mesh, shape.demo_constraints, options);
  using Clock = std::chrono::steady_clock;
  std::mutex mutex;
  std::vector<std::pair<int, Clock::time_point>> seen;  // iterations, when
  UpdatePipeline pipeline(deformer, [&](const UpdatePipeline::Result& result) {
    std::lock_guard lock(mutex);
    seen.emplace_back(result.refinement.iterations, Clock::now());
  });
  pipeline.set_refinement(true);
  pipeline.set_refinement_delay(std::chrono::milliseconds(120));
  Clock::time_point last_submit;
  for (int k = 1; k <= 5; ++k) {  // a drag: a request every 30 ms, never resting 120 ms
    const HandleTransform step = shape.demo_transform.at_fraction(k / 5.0);
    last_submit = Clock::now();
    pipeline.submit(std::span(&step, 1));
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
  }
  pipeline.wait_idle();
  std::lock_guard lock(mutex);
  ASSERT_FALSE(seen.empty());
  bool refined = false;
  for (const auto& [iterations, when] : seen) {
    if (iterations == 0) continue;
    refined = true;
    EXPECT_GE(when - last_submit, std::chrono::milliseconds(120));
  }
  EXPECT_TRUE(refined);
}

// The editor's drag asks for the proxy's vertices only: each answer is published as partial
// (solved on a base, only those are rebuilt), and once the input rests the rest follow,
// published whole, before the refinement; an exact solve, which wrote every vertex already, is
// published whole the same way. What the pipeline settles on is what whole requests give, to
// the last bit.
TEST(UpdatePipeline, APartialAnswerIsMadeWholeOnceTheInputRests) {
  auto shape = make_shape(ShapeKind::Cactus, 64);
  auto some = std::make_shared<std::vector<int>>();
  for (int v = 0; v < shape.mesh.vertex_count(); v += 5) some->push_back(v);
  using Clock = std::chrono::steady_clock;
  for (const auto resolution : {Resolution::Multiresolution, Resolution::Exact})
  for (const bool refine : {false, true}) {
    SCOPED_TRACE(std::string(to_string(resolution)) + (refine ? ", refinement on" : ", refinement off"));
    DeformerOptions options;
    options.resolution = resolution;
    options.base_vertices = shape.mesh.vertex_count() / 4;
    options.prepare_refinement = true;
    Deformer deformer(shape.mesh, shape.demo_constraints, options), reference(shape.mesh, shape.demo_constraints, options);
    struct Seen {
      bool partial, completion;
      int iterations;
      std::uint64_t request;
      Clock::time_point when;
    };
    std::mutex mutex;
    std::vector<Seen> seen;
    Eigen::MatrixXd last;
    UpdatePipeline pipeline(deformer, [&](const UpdatePipeline::Result& result) {
      std::lock_guard lock(mutex);
      seen.push_back({result.partial, result.completion, result.refinement.iterations, result.request, Clock::now()});
      last = result.positions;
    });
    pipeline.set_refinement(refine);
    pipeline.set_refinement_delay(std::chrono::milliseconds(100));
    Clock::time_point last_submit;
    std::uint64_t final_request = 0;
    HandleTransform step;
    for (int k = 1; k <= 4; ++k) {
      step = shape.demo_transform.at_fraction(k / 4.0);
      last_submit = Clock::now();
      final_request = pipeline.submit(std::span(&step, 1), some);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    const Eigen::MatrixXd settled = pipeline.settled_positions();
    EXPECT_EQ(pipeline.last_error(), nullptr);
    {
      std::lock_guard lock(mutex);
      ASSERT_FALSE(seen.empty());
      const auto completion = std::find_if(seen.begin(), seen.end(), [](const Seen& s) { return s.completion; });
      ASSERT_NE(completion, seen.end()) << "the partial answer was never made whole";
      EXPECT_EQ(std::count_if(seen.begin(), seen.end(), [](const Seen& s) { return s.completion; }), 1);
      EXPECT_FALSE(completion->partial);
      EXPECT_EQ(completion->request, final_request);
      EXPECT_GE(completion->when - last_submit, std::chrono::milliseconds(100));
      for (auto it = seen.begin(); it != completion; ++it) {
        EXPECT_TRUE(it->partial && it->iterations == 0) << "before the rest of the vertices: partial updates only";
      }
      for (auto it = completion + 1; it != seen.end(); ++it) EXPECT_TRUE(!it->partial && it->iterations > 0);
      EXPECT_EQ(last, settled);
    }
    // Whole requests settle on the same bits.
    UpdatePipeline whole(reference, [](const UpdatePipeline::Result&) {});
    whole.set_refinement(refine);
    whole.submit(std::span(&step, 1));
    EXPECT_TRUE((whole.settled_positions().array() == settled.array()).all());
    if (!refine) {
      Eigen::MatrixXd expected;
      Deformer fresh(shape.mesh, shape.demo_constraints, options);
      fresh.deform(std::span(&step, 1), expected);
      EXPECT_TRUE((settled.array() == expected.array()).all());
    }
  }
}

}  // namespace
}  // namespace hdeform

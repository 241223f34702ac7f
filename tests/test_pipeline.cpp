#include <atomic>
#include <mutex>

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
  UpdatePipeline pipeline(deformer, [&](const UpdatePipeline::Result&) { ++publications; });
  pipeline.submit(std::span(&shape.demo_transform, 1));
  pipeline.wait_idle();
  EXPECT_EQ(publications.load(), 1);
  const std::vector<HandleTransform> wrong_count(2);
  pipeline.submit(wrong_count);  // two transforms for one handle: the update throws
  pipeline.wait_idle();
  EXPECT_NE(pipeline.last_error(), nullptr);
  EXPECT_EQ(publications.load(), 1);
}

}  // namespace
}  // namespace hdeform

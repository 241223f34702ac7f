// The trace recorder (trace.h): off, the instrumented code makes no call into it; on, a drag
// update's file is valid trace-event JSON whose events nest per thread, whose stages lie inside
// their update, and whose solve runs its subtrees on both threads.
#include <tbb/global_control.h>

#include "hdeform/deformer.h"
#include "hdeform/shapes.h"
#include "hdeform/trace.h"
#include "hdeform/update_pipeline.h"
#include "test_support.h"
#include "trace_checks.h"

namespace hdeform {
namespace {

TEST(Trace, OffTheUpdatePathMakesNoCallIntoTheRecorder) {
  trace::stop();
  auto shape = make_shape(ShapeKind::Cylinder, 24);
  DeformerOptions options;
  options.prepare_refinement = true;
  Deformer deformer(shape.mesh, shape.demo_constraints, options);
  Eigen::MatrixXd positions;
  const auto before = trace::recorder_calls();
  for (int k = 1; k <= 5; ++k) {
    const HandleTransform step = shape.demo_transform.at_fraction(k / 5.0);
    deformer.deform(std::span(&step, 1), positions);
    deformer.refine(positions, 3);
  }
  {
    UpdatePipeline pipeline(deformer, [](const UpdatePipeline::Result&) {});
    pipeline.set_refinement(true);
    pipeline.submit(std::span(&shape.demo_transform, 1));
    pipeline.wait_idle();
  }
  EXPECT_EQ(trace::recorder_calls(), before);
  // ... and on, the same calls record.
  trace::start(1 << 12);
  deformer.deform(std::span(&shape.demo_transform, 1), positions);
  trace::stop();
  EXPECT_GT(trace::recorder_calls(), before);
  EXPECT_GT(trace::recorded_events(), 5u);
}

TEST(Trace, ADragsEventsNestPerThreadAndTheSolveRunsOnBothThreads) {
  const tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
  auto shape = make_shape(ShapeKind::Cactus, 64);  // over 1,024 free rows: the solve splits into subtrees
  const test::TempDir dir;
  trace::start();
  DeformerOptions options;
  options.prepare_refinement = true;
  Deformer deformer(shape.mesh, shape.demo_constraints, options);
  Eigen::MatrixXd positions;
  for (int k = 1; k <= 20; ++k) {
    const HandleTransform step = shape.demo_transform.at_fraction(k / 20.0);
    deformer.deform(std::span(&step, 1), positions);
    deformer.refine(positions, 2);
  }
  trace::stop();
  trace::write(dir.file("trace.json"));
  const auto events = test::read_checked_trace(dir.file("trace.json"));
  for (const std::string stage : {"cotangent weights", "mesh inspection", "vertex partition", "Laplacian", "factorization",
                                  "elimination order (AMD)",
                                  "analysis (elimination tree, pattern of L)", "numeric factorization", "harmonic field", "refinement set-up"}) {
    EXPECT_EQ(test::named(events, stage).size(), 1u) << stage;
  }
  const auto updates = test::named(events, "update");
  ASSERT_EQ(updates.size(), 20u);
  EXPECT_EQ(test::named(events, "refinement iteration").size(), 40u);
  // Each stage of an update lies inside one of the updates, whichever thread ran it.
  std::size_t stages = 0;
  for (const auto& event : events) {
    if (event.category != "update" || event.name == "update" || event.name.starts_with("refinement")) continue;
    ++stages;
    const bool inside = std::any_of(updates.begin(), updates.end(), [&](const test::TraceEvent& update) {
      return event.start_us >= update.start_us - 1e-3 && event.end_us() <= update.end_us() + 1e-3;
    });
    EXPECT_TRUE(inside) << event.name << " at " << event.start_us << " lies in no update";
  }
  EXPECT_GE(stages, 20u * 5u);  // targets, maps, right-hand side, solve, write-back
  const auto subtrees = test::named(events, "forward sweep, subtree");
  EXPECT_GE(subtrees.size(), 20u * 2u);
  // Two subtrees, and (once the second thread has had the processor: on a loaded machine the
  // first updates may run both on one) both threads run them.
  std::size_t threads = test::threads_of(subtrees).size();
  for (int attempt = 0; attempt < 50 && threads < 2; ++attempt) {
    trace::start();
    for (int k = 0; k < 10; ++k) deformer.deform(std::span(&shape.demo_transform, 1), positions);
    trace::stop();
    trace::write(dir.file("more.json"));
    threads = test::threads_of(test::named(test::read_checked_trace(dir.file("more.json")), "forward sweep, subtree")).size();
  }
  EXPECT_EQ(threads, 2u) << "the solve's subtrees ran on one thread only";
}

TEST(Trace, ACommandWritesItsTimelineAndNothingWhenItFails) {
  const test::TempDir dir;
  const auto run = test::run_command(std::string(HDEFORM_EXECUTABLE) + " edit --shape cylinder --steps 3 --refine 2 --out " +
                                         dir.file("out.obj").string() + " --trace " + dir.file("edit.json").string() + " --quiet",
                                     dir.path());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  const auto events = test::read_checked_trace(dir.file("edit.json"));
  EXPECT_EQ(test::named(events, "update").size(), 3u);
  EXPECT_EQ(test::named(events, "refinement iteration").size(), report["refine"]["iterations"].get<std::size_t>());
  EXPECT_EQ(report.value("trace", ""), dir.file("edit.json").string());
  EXPECT_EQ(test::named(events, "factorization").size(), 1u);
  // A failed command writes no trace either.
  dir.write("bad.obj", "v 0 0 0\n");
  const auto failed = test::run_command(std::string(HDEFORM_EXECUTABLE) + " edit --mesh " + dir.file("bad.obj").string() +
                                            " --fixed x --handle y --transform z --out " + dir.file("out2.obj").string() + " --trace " +
                                            dir.file("failed.json").string() + " --quiet",
                                        dir.path());
  EXPECT_EQ(failed.exit_code, 1);
  EXPECT_FALSE(std::filesystem::exists(dir.file("failed.json")));
}

}  // namespace
}  // namespace hdeform

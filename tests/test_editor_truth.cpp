// The editor's document, window-free: what it shows once settled is what it saves and what
// `edit` computes, whatever poses came before.
#include <chrono>
#include <mutex>
#include <thread>

#include "model/document.h"
#include "hdeform/shapes.h"
#include "model/session.h"
#include "test_support.h"

namespace hdeform {
namespace {

// What the screen shows once settled is what is saved and what `edit` computes, whatever poses came
// before: the editor's reproductions of the stall (a drag reversed past the rest shape, a reset
// then a drag another way, an undo to an earlier pose, a typed move of +0.5 then -0.5), driven through
// the document window-free, with refinement interleaved with the requests as the pipeline runs it.
class ShownShapeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    shape = make_shape(ShapeKind::Cylinder, 16);
    cli::Session session;
    session.mesh = "shape:cylinder:16";
    session.current.fixed = shape.demo_constraints.fixed;
    session.current.handles.push_back({shape.demo_constraints.handles[0], HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), pivot(), 0.0)});
    session.current.refine = true;
    session.current.refine_settle = kEditorSettle;
    document = std::make_unique<cli::Document>(session, shape.mesh, DeformerOptions{}, [this](const Eigen::MatrixXd& positions, std::uint64_t, cli::Document::Answer) {
      std::lock_guard lock(mutex);
      shown = positions;
    });
    document->wait_until_ready();
    ASSERT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
  }
  Eigen::Vector3d pivot() const {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const int v : shape.demo_constraints.handles[0]) sum += shape.mesh.positions.row(v).transpose();
    return sum / static_cast<double>(shape.demo_constraints.handles[0].size());
  }
  // A drag of the handle's shift from `from` to `to` in `steps` moves, a few milliseconds apart.
  void drag(const Eigen::Vector3d& from, const Eigen::Vector3d& to, int steps) {
    for (int k = 1; k <= steps; ++k) {
      document->set_pose(0, Eigen::Vector3d::UnitZ(), 0.0, 1.0, from + (to - from) * (static_cast<double>(k) / steps));
      document->request_update();
      std::this_thread::sleep_for(std::chrono::milliseconds(3));
    }
    document->commit("move handle 1");
  }
  void settle() {
    for (int k = 0; k < 2000 && !document->settled(); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    ASSERT_TRUE(document->settled());
  }
  // Settled: the screen, the saved result, the batch replay of the session and a fresh deformer
  // at the pose (as `edit --refine auto --refine-settle`) are the same bits, with the same energies.
  void expect_one_truth(const std::string& what) {
    SCOPED_TRACE(what);
    ASSERT_NO_FATAL_FAILURE(settle());
    Eigen::MatrixXd on_screen;
    {
      std::lock_guard lock(mutex);
      on_screen = shown;
    }
    const Eigen::MatrixXd saved = document->result();
    EXPECT_EQ(on_screen, saved);
    const auto session = document->session();
    EXPECT_EQ(cli::replay_session(session, shape.mesh, {}), saved);
    DeformerOptions options;
    options.prepare_refinement = true;
    options.refinement.settle = kEditorSettle;
    Deformer fresh(shape.mesh, session.current.constraints(), options);
    Eigen::MatrixXd expected;
    fresh.deform(session.current.transforms(), expected);
    fresh.refine(expected, options.refinement.max_iterations);
    EXPECT_EQ(saved, expected);
    const auto view = document->refinement();
    EXPECT_EQ(view.status.energy, fresh.refinement_status().energy);
    EXPECT_EQ(view.status.unrefined_energy, fresh.refinement_status().unrefined_energy);
    EXPECT_EQ(view.status.iterations, fresh.refinement_status().iterations);
    EXPECT_TRUE(view.status.converged);
  }
  Shape shape;
  std::unique_ptr<cli::Document> document;
  std::mutex mutex;
  Eigen::MatrixXd shown;
};

TEST_F(ShownShapeTest, ADragReversedPastTheRestShape) {
  const Eigen::Vector3d right(0.5, 0.0, 0.0);
  drag(Eigen::Vector3d::Zero(), right, 20);
  expect_one_truth("dragged right");
  EXPECT_GT(document->refinement().status.iterations, 3);
  drag(right, -right, 40);
  expect_one_truth("dragged back left past the rest shape");
  EXPECT_GT(document->refinement().status.iterations, 3) << "the stall: one iteration and 'settled'";
  EXPECT_LT(document->refinement().status.energy, 0.5 * document->refinement().status.unrefined_energy);
}

TEST_F(ShownShapeTest, AResetThenADragAnotherWay) {
  drag(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.5, 0.0, 0.0), 20);
  expect_one_truth("dragged right");
  document->reset_poses();
  document->request_update();
  document->commit("reset the handles");
  expect_one_truth("reset");
  drag(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.0, 0.4, 0.0), 20);
  expect_one_truth("dragged another way");
}

TEST_F(ShownShapeTest, AnUndoToAnEarlierPoseAndARedo) {
  drag(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.5, 0.0, 0.0), 20);
  expect_one_truth("first pose");
  drag(Eigen::Vector3d(0.5, 0.0, 0.0), Eigen::Vector3d(-0.3, 0.2, 0.0), 20);
  expect_one_truth("second pose");
  ASSERT_TRUE(document->undo());
  document->request_update();
  expect_one_truth("undone to the first pose");
  ASSERT_TRUE(document->redo());
  document->request_update();
  expect_one_truth("redone");
}

TEST_F(ShownShapeTest, ATypedMoveThenItsOpposite) {
  for (const double x : {0.5, -0.5}) {
    document->set_pose(0, Eigen::Vector3d::UnitZ(), 0.0, 1.0, Eigen::Vector3d(x, 0.0, 0.0));
    document->request_update();
    document->commit("the pose of handle 1 typed");
    expect_one_truth("typed x = " + std::to_string(x));
  }
}

}  // namespace
}  // namespace hdeform

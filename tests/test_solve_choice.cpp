// Where the editor's session solves (on every vertex or on a base mesh, and how its factors are
// stored), chosen in the panel: part of the state, undoable, and what `hdeform edit --session`
// replays.
#include <gtest/gtest.h>

#include <span>
#include <stdexcept>

#include "hdeform/mesh.h"
#include "hdeform/shapes.h"
#include "model/document.h"

namespace hdeform {
namespace {

class SolveChoiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    shape = make_shape(ShapeKind::Cactus, 24);
    cli::Session session;
    session.mesh = "shape:cactus:24";
    document = std::make_unique<cli::Document>(session, shape.mesh, DeformerOptions{}, nullptr);
    document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
    document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
    document->set_pose(0, Eigen::Vector3d::UnitX(), 1.2, 1.0, Eigen::Vector3d(0.0, -0.05, 0.0));
    document->commit();
  }
  // The document's result, checked against the batch replay of its session.
  Eigen::MatrixXd replayed_result() {
    const Eigen::MatrixXd result = document->result();
    EXPECT_EQ(result, cli::replay_session(document->session(), shape.mesh, {}));
    return result;
  }
  cli::Document::SolveChoice on_base(Eigen::Index vertices) const { return {Resolution::Multiresolution, vertices, FactorPrecision::Double}; }

  Shape shape;
  std::unique_ptr<cli::Document> document;
};

TEST_F(SolveChoiceTest, EachChoiceSolvesAsItsReplayAndUndoGoesBackToTheLastBit) {
  ASSERT_EQ(document->solve_choice().resolution, Resolution::Exact) << "a mesh this small opens exact";
  const Eigen::Index n = document->vertex_count();
  const Eigen::MatrixXd exact = replayed_result();
  EXPECT_EQ(document->solved_vertex_count(), n);

  document->set_solve_choice(on_base(n / 4));
  document->commit("solve on a base");
  EXPECT_EQ(document->session().resolution, Resolution::Multiresolution);
  EXPECT_EQ(document->session().base_vertices, n / 4);
  const Eigen::MatrixXd coarse = replayed_result();
  EXPECT_LT(document->solved_vertex_count(), n / 2) << "solved on the base";
  EXPECT_GT((coarse - exact).cwiseAbs().maxCoeff(), 0.0);

  // Another base: built again, not the previous base's operators reused.
  document->set_solve_choice(on_base(n / 2));
  document->commit("a larger base");
  const Eigen::MatrixXd finer = replayed_result();
  EXPECT_GT(document->solved_vertex_count(), 3 * n / 8);

  cli::Document::SolveChoice single = on_base(n / 2);
  single.precision = FactorPrecision::Single;
  document->set_solve_choice(single);
  document->commit("single precision");
  EXPECT_EQ(document->session().precision, FactorPrecision::Single);
  const Eigen::MatrixXd refined = replayed_result();
  EXPECT_EQ(document->factor_precision(), FactorPrecision::Single);
  EXPECT_LT((refined - finer).cwiseAbs().maxCoeff(), 1e-10 * bounding_box_diagonal(shape.mesh.positions));

  ASSERT_TRUE(document->undo());
  EXPECT_EQ(document->solve_choice(), on_base(n / 2));
  EXPECT_EQ(document->result(), finer);
  ASSERT_TRUE(document->undo());
  EXPECT_EQ(document->result(), coarse);
  ASSERT_TRUE(document->undo());
  EXPECT_EQ(document->solve_choice().resolution, Resolution::Exact);
  EXPECT_EQ(document->result(), exact);
  EXPECT_EQ(document->solved_vertex_count(), n);
  ASSERT_TRUE(document->redo());
  EXPECT_EQ(document->result(), coarse);
}

TEST_F(SolveChoiceTest, WhileTheNewChoiceIsSetUpTheDragGoesOnWithTheSetUpInPlace) {
  document->wait_until_ready();
  document->set_solve_choice(on_base(document->vertex_count() / 4));
  document->poll();
  ASSERT_EQ(document->solver_state(), cli::Document::SolverState::Building);
  EXPECT_TRUE(document->drags_previous_selection());
  document->set_pose(0, Eigen::Vector3d::UnitX(), 0.6, 1.0, Eigen::Vector3d::Zero());
  EXPECT_NE(document->request_update(), 0U) << "the exact set-up answers the drag meanwhile";
  document->wait_until_ready();
  EXPECT_FALSE(document->drags_previous_selection());
  EXPECT_LT(document->solved_vertex_count(), document->vertex_count());
}

// A switch undone at once: the set-up for it stops at its next stage instead of holding up the
// one after it (on a scan, for the rest of a factorization of every vertex), and the set-up in
// place answers on.
TEST(SolveChoice, ASetUpNoLongerWantedStopsEarly) {
  const Shape big = make_shape(ShapeKind::Cactus, 160);
  cli::Session session;
  session.mesh = "shape:cactus:160";
  cli::Document document(session, big.mesh, DeformerOptions{}, nullptr);
  document.paint(big.demo_constraints.fixed, cli::Layer::Fixed, false);
  document.paint(big.demo_constraints.handles[0], cli::Layer::Handle, false);
  document.commit();
  document.wait_until_ready();
  const Eigen::MatrixXd exact = document.result();
  ASSERT_GT(document.vertex_count(), 50000) << "a set-up long enough to be stopped";
  document.set_solve_choice({Resolution::Multiresolution, document.vertex_count() / 8, FactorPrecision::Double});
  document.commit("solve on a base");
  document.poll();
  ASSERT_EQ(document.solver_state(), cli::Document::SolverState::Building);
  ASSERT_TRUE(document.undo());
  document.wait_until_ready();
  EXPECT_EQ(document.set_ups_stopped(), 1U);
  EXPECT_EQ(document.solved_vertex_count(), document.vertex_count()) << "the exact set-up still in place";
  EXPECT_EQ(document.result(), exact);
  // Changing only the selection lets the set-up finish: its operators serve the next one.
  const auto& handle = big.demo_constraints.handles[0];
  document.paint(std::span(handle.data(), handle.size() / 2), cli::Layer::Handle, true);
  document.poll();
  document.paint(handle, cli::Layer::Handle, false);
  document.wait_until_ready();
  EXPECT_EQ(document.set_ups_stopped(), 1U);
}

TEST_F(SolveChoiceTest, AnAppliedStageFixesWhereTheSessionSolves) {
  document->apply();
  document->commit("apply");
  EXPECT_FALSE(document->can_change_solve_choice());
  EXPECT_THROW(document->set_solve_choice(on_base(100)), std::logic_error);
  EXPECT_EQ(document->solve_choice().resolution, Resolution::Exact);
  ASSERT_TRUE(document->undo());
  EXPECT_TRUE(document->can_change_solve_choice());
  EXPECT_THROW(document->set_solve_choice({Resolution::Automatic, 100, FactorPrecision::Double}), std::invalid_argument);
  EXPECT_THROW(document->set_solve_choice(on_base(3)), std::invalid_argument);
  document->set_solve_choice(on_base(100));
  EXPECT_EQ(document->solve_choice(), on_base(100));
}

}  // namespace
}  // namespace hdeform

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <mutex>
#include <new>
#include <random>
#include <set>
#include <thread>

#include "model/document.h"
#include "gui/frame_statistics.h"
#include "gui/recent_files.h"
#include "gui/recovery.h"
#include "gui/synthetic_drag.h"
#include "gui/restore_prompt.h"
#include "model/transfer_state.h"
#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "model/marker_editor.h"
#include "test_support.h"

namespace hdeform {
namespace {

class DocumentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    shape = make_shape(ShapeKind::Cactus, 24);
    cli::Session session;
    session.mesh = "shape:cactus:24";
    document = std::make_unique<cli::Document>(session, shape.mesh, DeformerOptions{}, [this](const Eigen::MatrixXd&, std::uint64_t, cli::Document::Answer) { ++publications; });
  }
  Shape shape;
  std::unique_ptr<cli::Document> document;
  std::atomic<int> publications{0};
};

// The adjacency is each vertex's edge neighbours, built on first use or beforehand on a thread of
// its own; checked against the triangles' edges, collected here.
TEST_F(DocumentTest, TheAdjacencyIsTheMeshsEdgesBuiltOnUseOrBeforehand) {
  std::vector<std::set<int>> expected(static_cast<std::size_t>(shape.mesh.vertex_count()));
  for (Eigen::Index t = 0; t < shape.mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = shape.mesh.triangles(t, k), b = shape.mesh.triangles(t, (k + 1) % 3);
      expected[static_cast<std::size_t>(a)].insert(b);
      expected[static_cast<std::size_t>(b)].insert(a);
    }
  }
  auto check = [&](const cli::VertexAdjacency& adjacency) {
    ASSERT_EQ(adjacency.vertex_count(), expected.size());
    for (std::size_t v = 0; v < expected.size(); ++v) {
      const auto listed = adjacency.neighbours(static_cast<int>(v));
      EXPECT_EQ(std::vector<int>(listed.begin(), listed.end()), std::vector<int>(expected[v].begin(), expected[v].end())) << "vertex " << v;
    }
  };
  check(document->adjacency());
  cli::Session session;
  session.mesh = "shape:cactus:24";
  cli::Document prepared(session, shape.mesh, DeformerOptions{}, {});
  prepared.prepare_adjacency();
  prepared.prepare_adjacency();  // once is enough
  check(prepared.adjacency());
}

TEST_F(DocumentTest, PaintingKeepsFixedAndHandlesExclusiveAndUndoes) {
  const auto& fixed = shape.demo_constraints.fixed;
  const auto& handle = shape.demo_constraints.handles[0];
  document->paint(fixed, cli::Layer::Fixed, false);
  document->commit();
  document->paint(handle, cli::Layer::Handle, false);
  document->commit();
  EXPECT_EQ(document->handle_count(), 1u);
  EXPECT_EQ(document->session().current.fixed, fixed);
  EXPECT_EQ(document->session().current.handles.at(0).vertices, handle);
  // Painting fixed over a handle vertex takes it from the handle.
  document->paint(std::vector<int>{handle[0]}, cli::Layer::Fixed, false);
  EXPECT_EQ(document->label(handle[0]), cli::Document::kFixed);
  EXPECT_EQ(document->handle_size(0), handle.size() - 1);
  document->commit();
  ASSERT_TRUE(document->undo());
  EXPECT_EQ(document->label(handle[0]), 0);
  ASSERT_TRUE(document->undo());
  EXPECT_EQ(document->handle_count(), 0u);  // before the handle was painted
  ASSERT_TRUE(document->redo());
  EXPECT_EQ(document->session().current.handles.at(0).vertices, handle);
  // Invert the fixed set: every vertex that is neither fixed nor in the handle becomes fixed.
  document->invert(cli::Layer::Fixed);
  const auto session = document->session();
  EXPECT_EQ(session.current.fixed.size() + fixed.size() + handle.size(), static_cast<std::size_t>(shape.mesh.vertex_count()));
}

// A state restored after a crash is in no file: it counts as unsaved, whatever undo and redo do,
// until it is saved.
TEST_F(DocumentTest, RestoredWorkStaysUnsavedUntilSaved) {
  EXPECT_FALSE(document->modified());
  document->mark_unsaved();
  EXPECT_TRUE(document->modified());
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->commit();
  ASSERT_TRUE(document->undo());
  EXPECT_TRUE(document->modified()) << "undo back to the restored state is still unsaved";
  document->mark_saved();
  EXPECT_FALSE(document->modified());
}

// While a stroke is painted its selection is not final: no set-up starts until it ends (at 13M
// triangles a set-up takes 25 s and cannot be stopped).
TEST_F(DocumentTest, NoSetUpStartsWhileAStrokeIsPainted) {
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->hold_set_up(true);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->poll();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::NoHandle);
  document->hold_set_up(false);
  document->poll();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Building);
  document->wait_until_ready();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
}

// A set-up overtaken by a new selection is not installed, but what it computed for the rest shape
// alone (the base mesh of a scan: most of its time) serves the next one.
TEST_F(DocumentTest, AStaleSetUpLeavesItsOperatorsToTheNext) {
  const auto& handle = shape.demo_constraints.handles[0];
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(std::span(handle.data(), handle.size() / 2), cli::Layer::Handle, false);
  document->poll();
  ASSERT_EQ(document->solver_state(), cli::Document::SolverState::Building);
  EXPECT_FALSE(document->set_up_reuses_operators()) << "the first set-up on this mesh";
  document->paint(handle, cli::Layer::Handle, false);  // the selection changes while it runs
  while (document->solver_state() == cli::Document::SolverState::Building && !document->set_up_reuses_operators()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    document->poll();
  }
  EXPECT_TRUE(document->set_up_reuses_operators()) << "the second set-up computed the operators again";
  document->wait_until_ready();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
  EXPECT_EQ(document->handle_size(0), handle.size());
}

// A save is written on a thread of its own: the state it wrote is saved only if it is still the
// state when the files are done (a key pressed in the frame of Ctrl+S may have changed it).
TEST_F(DocumentTest, ASaveMarksSavedOnlyTheStateItWrote) {
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->commit();
  const cli::Session written = document->session();
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->commit();
  document->mark_saved(written);
  EXPECT_TRUE(document->modified()) << "the handle painted while the save was written is not in it";
  ASSERT_TRUE(document->undo());
  document->mark_saved(written);
  EXPECT_FALSE(document->modified());
  ASSERT_TRUE(document->redo());
  EXPECT_TRUE(document->modified());
}

// A value typed into the panel is applied as the user types, and committed when the field is
// left; undo and redo before that must neither drop it nor bring back an older pose.
TEST_F(DocumentTest, AnUncommittedChangeIsNeverLostToUndoOrRedo) {
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->commit();
  const Eigen::Vector3d twist_axis = Eigen::Vector3d::UnitZ();
  document->set_pose(0, twist_axis, 2.0, 1.0, Eigen::Vector3d::Zero());  // an older twist
  document->commit();
  ASSERT_TRUE(document->undo());
  EXPECT_EQ(document->pose(0).angle, 0.0);
  const Eigen::Vector3d typed(10.0, 0.0, 0.0);
  document->set_pose(0, twist_axis, 0.0, 1.0, typed);  // Move X = 10, still in the field
  EXPECT_FALSE(document->redo());                      // the twist is not resurrected over it
  EXPECT_EQ(document->pose(0).shift, typed);
  EXPECT_TRUE(document->modified());
  ASSERT_TRUE(document->undo());  // back to the step before the typed move
  EXPECT_EQ(document->pose(0).shift, Eigen::Vector3d::Zero());
  EXPECT_EQ(document->pose(0).angle, 0.0);
  ASSERT_TRUE(document->redo());  // and the typed move again, not the twist
  EXPECT_EQ(document->pose(0).shift, typed);
  EXPECT_EQ(document->pose(0).angle, 0.0);
  EXPECT_FALSE(document->redo());
  // The first change of a fresh document is undoable too.
  cli::Session session;
  session.mesh = "shape:cactus:24";
  cli::Document fresh(session, shape.mesh, DeformerOptions{}, {});
  fresh.paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  ASSERT_TRUE(fresh.undo());
  EXPECT_TRUE(fresh.session().current.fixed.empty());
}

TEST_F(DocumentTest, TheResultIsTheBatchReplayOfItsSessionAndApplyChainsStages) {
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->set_pose(0, Eigen::Vector3d::UnitX(), 1.2, 1.0, Eigen::Vector3d(0.0, -0.05, 0.0));
  document->commit();
  document->wait_until_ready();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
  ASSERT_NE(document->field(), nullptr);
  const Eigen::MatrixXd result = document->result();
  EXPECT_EQ(result, cli::replay_session(document->session(), shape.mesh, {}));
  EXPECT_GT((result - shape.mesh.positions).cwiseAbs().maxCoeff(), 0.02);
  // The pipeline published at least one update on its own thread.
  for (int k = 0; k < 200 && publications.load() == 0; ++k) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_GT(publications.load(), 0);

  document->apply();
  document->commit();
  EXPECT_EQ(document->rest().positions, result);
  EXPECT_EQ(document->pose(0).angle, 0.0);
  document->set_pose(0, Eigen::Vector3d::UnitX(), 0.5, 1.0, Eigen::Vector3d::Zero());
  const Eigen::MatrixXd second = document->result();
  EXPECT_EQ(second, cli::replay_session(document->session(), shape.mesh, {}));
  ASSERT_TRUE(document->undo());  // the pose set after apply (uncommitted, so undo records it first)
  EXPECT_EQ(document->pose(0).angle, 0.0);
  EXPECT_EQ(document->rest().positions, result);
  ASSERT_TRUE(document->undo());  // back before apply
  EXPECT_EQ(document->rest().positions, shape.mesh.positions);
}

// With refinement on, the pipeline refines in the background after each drag step; what the
// document saves and applies is exactly the batch replay of its session.
TEST_F(DocumentTest, ARefinedResultIsTheBatchReplayWhateverThePipelineShowed) {
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->set_refine(true);
  document->commit();
  document->wait_until_ready();
  for (int step = 1; step <= 5; ++step) {
    document->set_pose(0, Eigen::Vector3d::UnitX(), 0.0, 1.0, Eigen::Vector3d(0.0, -0.04 * step, 0.0));
    document->request_update();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  document->commit();  // the end of the drag: one step
  for (int k = 0; k < 400 && !document->refinement().status.converged; ++k) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_GT(document->refinement().status.iterations, 0);
  const auto session = document->session();
  EXPECT_TRUE(session.current.refine);
  const Eigen::MatrixXd result = document->result();
  EXPECT_EQ(result, cli::replay_session(session, shape.mesh, {}));
  document->set_refine(false);
  document->commit();
  EXPECT_NE(document->result(), result);
  ASSERT_TRUE(document->undo());  // the setting is part of the state
  EXPECT_TRUE(document->refine());
  EXPECT_EQ(document->result(), result);
  document->apply();
  document->commit();
  EXPECT_EQ(document->rest().positions, result);
  EXPECT_EQ(cli::replay_session(document->session(), shape.mesh, {}), document->result());  // the applied stage replays refined
}

TEST_F(DocumentTest, ARebuildRunsOffTheCallingThreadAndTheStateSaysSo) {
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::NoHandle);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->poll();
  const auto state = document->solver_state();
  EXPECT_TRUE(state == cli::Document::SolverState::Building || state == cli::Document::SolverState::Ready);
  document->wait_until_ready();
  // A handle with no fixed vertex: refused with the reason, nothing to show.
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Failed);
  EXPECT_NE(document->solver_message().find("no fixed vertex"), std::string::npos) << document->solver_message();
  EXPECT_EQ(document->field(), nullptr);
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->poll();
  document->wait_until_ready();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
  EXPECT_NE(document->field(), nullptr);
}

// A stroke never stops the drag: while the new selection is factored, the poses are solved with
// the previous one, and the new set-up then solves them again.
TEST_F(DocumentTest, WhileANewSelectionIsSetUpTheDragUsesThePreviousOne) {
  std::mutex mutex;
  std::vector<std::pair<std::uint64_t, Eigen::MatrixXd>> published;
  document->set_publish([&](const Eigen::MatrixXd& positions, std::uint64_t request, cli::Document::Answer) {
    const std::lock_guard lock(mutex);
    published.emplace_back(request, positions);
  });
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->commit();
  document->wait_until_ready();
  ASSERT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
  EXPECT_FALSE(document->drags_previous_selection());

  // A stroke adds a free vertex next to the handle: a new set-up starts (and is not installed
  // before the next poll).
  int added = -1;
  for (const int v : shape.demo_constraints.handles[0]) {
    for (const int w : document->adjacency().neighbours(v)) {
      if (document->label(w) == cli::Document::kFree) added = w;
    }
  }
  ASSERT_GE(added, 0);
  const std::vector<int> old_handle = shape.demo_constraints.handles[0];
  document->paint(std::span(&added, 1), cli::Layer::Handle, false);
  document->commit();
  document->poll();
  ASSERT_EQ(document->solver_state(), cli::Document::SolverState::Building);
  EXPECT_TRUE(document->drags_previous_selection());
  document->set_pose(0, Eigen::Vector3d::UnitX(), 0.6, 1.0, Eigen::Vector3d(0.1, 0.0, 0.0));
  const std::uint64_t provisional = document->request_update();
  ASSERT_GT(provisional, 0u);
  for (int k = 0; k < 400; ++k) {
    {
      const std::lock_guard lock(mutex);
      if (!published.empty() && published.back().first == provisional) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  Eigen::MatrixXd shown;
  {
    const std::lock_guard lock(mutex);
    ASSERT_EQ(published.back().first, provisional);
    shown = published.back().second;
  }
  // The previous selection's answer: its handle follows the pose exactly, the added vertex is
  // still free (not where the pose puts it), the fixed vertices stay.
  const HandleTransform& pose = document->pose(0);
  for (const int v : old_handle) {
    EXPECT_LE((shown.row(v).transpose() - pose.apply(shape.mesh.positions.row(v).transpose())).norm(), 1e-12);
  }
  EXPECT_GT((shown.row(added).transpose() - pose.apply(shape.mesh.positions.row(added).transpose())).norm(), 1e-6);
  for (const int v : shape.demo_constraints.fixed) EXPECT_EQ(shown.row(v), shape.mesh.positions.row(v));

  // Once the new set-up is in, the same poses are solved with it: the batch replay's result.
  document->wait_until_ready();
  EXPECT_FALSE(document->drags_previous_selection());
  const Eigen::MatrixXd final_result = document->result();
  EXPECT_LE((final_result.row(added).transpose() - pose.apply(shape.mesh.positions.row(added).transpose())).norm(), 1e-12);
  for (int k = 0; k < 400; ++k) {
    {
      const std::lock_guard lock(mutex);
      if (published.back().first > provisional) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const std::lock_guard lock(mutex);
  ASSERT_GT(published.back().first, provisional);
  EXPECT_LE((published.back().second - final_result).norm(), 1e-9 * final_result.norm());
}

// A stroke that empties one of two handles leaves the previous deformer with a pose too many:
// the drag waits for the new set-up instead.
TEST_F(DocumentTest, ADragDuringASetUpNeedsAsManyHandlesAsThePreviousSelection) {
  const auto& handle = shape.demo_constraints.handles[0];
  const std::vector<int> first(handle.begin(), handle.begin() + static_cast<std::ptrdiff_t>(handle.size() / 2));
  const std::vector<int> second(handle.begin() + static_cast<std::ptrdiff_t>(handle.size() / 2), handle.end());
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(first, cli::Layer::Handle, false);
  document->add_handle();
  document->paint(second, cli::Layer::Handle, false);
  document->commit();
  document->wait_until_ready();
  ASSERT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
  ASSERT_GT(document->request_update(), 0u);

  document->paint(second, cli::Layer::Handle, true);  // handle 2 erased: still listed, now empty
  document->commit();
  ASSERT_EQ(document->handle_count(), 2u);
  ASSERT_EQ(document->handle_size(1), 0u);
  document->poll();
  ASSERT_EQ(document->solver_state(), cli::Document::SolverState::Building);
  EXPECT_FALSE(document->drags_previous_selection());
  EXPECT_EQ(document->request_update(), 0u);
  document->wait_until_ready();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
  EXPECT_GT(document->request_update(), 0u);
}

// The window is woken after each publication with the state already recorded (so a frame can
// tell the final shape), and once more when a finished refinement's digest is there: the first
// wake after it already finds the refinement finished, before its digest.
TEST_F(DocumentTest, TheWindowWakesWithThePublicationsStateAndAgainWithItsDigest) {
  struct Wake {
    int publications;
    std::uint64_t published;
    cli::Document::RefinementView view;
  };
  std::mutex mutex;
  std::vector<Wake> wakes;
  std::vector<std::uint64_t> requests;  // of each publication, in order
  std::vector<cli::Document::Answer> answers;
  document->set_publish([&](const Eigen::MatrixXd&, std::uint64_t request, cli::Document::Answer answer) {
    const std::lock_guard lock(mutex);
    requests.push_back(request);
    answers.push_back(answer);
  });
  document->set_wake([&] {
    const std::lock_guard lock(mutex);
    wakes.push_back({static_cast<int>(requests.size()), document->last_published_request(), document->refinement()});
  });
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->set_refine(true);
  document->set_pose(0, Eigen::Vector3d::UnitX(), 0.0, 1.0, Eigen::Vector3d(0.0, -0.2, 0.0));
  document->commit();
  const Eigen::MatrixXd result = document->result();
  for (int k = 0; k < 400; ++k) {
    if (!document->refinement().digest.empty()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_TRUE(document->settled());
  const std::lock_guard lock(mutex);
  ASSERT_FALSE(requests.empty());
  ASSERT_GE(wakes.size(), 2u);
  for (const Wake& wake : wakes) {
    ASSERT_GT(wake.publications, 0) << "woken before anything was published";
    EXPECT_EQ(wake.published, requests[static_cast<std::size_t>(wake.publications) - 1]) << "woken before the state was recorded";
    EXPECT_EQ(wake.view.request, wake.published);
  }
  const Wake& finished = wakes[wakes.size() - 2];
  const Wake& digested = wakes.back();
  EXPECT_EQ(finished.publications, static_cast<int>(requests.size()));
  EXPECT_TRUE(finished.view.finished);
  EXPECT_TRUE(finished.view.digest.empty()) << "the finished shape waited for its digest";
  EXPECT_TRUE(digested.view.finished);
  EXPECT_EQ(digested.publications, finished.publications);
  EXPECT_EQ(digested.view.digest, cli::positions_digest(result));
  for (std::size_t k = 0; k + 2 < wakes.size(); ++k) EXPECT_FALSE(wakes[k].view.finished) << "wake " << k;
  // The paper's update, the iterations with more to come (settling), the last.
  ASSERT_GE(answers.size(), 3u);
  EXPECT_EQ(answers.front(), cli::Document::Answer::Whole);
  EXPECT_EQ(answers.back(), cli::Document::Answer::Refined);
  for (std::size_t k = 1; k + 1 < answers.size(); ++k) EXPECT_EQ(answers[k], cli::Document::Answer::Settling) << "publication " << k;
}

// A refinement that fails (here out of memory as its first iteration is handed over) ends the
// wait for these poses: settled() says so, the window is woken to show why, and result() throws
// the reason instead of giving a shape that is not the session's (a save would wait for ever, or
// write it). New poses, or refinement turned off, are answered as usual.
TEST_F(DocumentTest, AFailedRefinementSettlesWithItsReasonAndNewPosesSolveAgain) {
  std::atomic<bool> fail_next_iteration{true};
  std::mutex mutex;
  std::vector<std::string> woken_with;  // the failure each wake found
  document->set_publish([&](const Eigen::MatrixXd&, std::uint64_t, cli::Document::Answer answer) {
    if (answer == cli::Document::Answer::Settling && fail_next_iteration.exchange(false)) throw std::bad_alloc();
  });
  document->set_wake([&] {
    const std::lock_guard lock(mutex);
    woken_with.push_back(document->answer_failure().why);
  });
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->set_refine(true);
  document->set_pose(0, Eigen::Vector3d::UnitX(), 0.0, 1.0, Eigen::Vector3d(0.0, -0.2, 0.0));
  document->commit();
  try {
    (void)document->result();
    ADD_FAILURE() << "result() gave a shape the refinement never reached";
  } catch (const SolveError& error) {
    EXPECT_NE(std::string(error.what()).find("The refinement stopped: out of memory"), std::string::npos) << error.what();
  }
  EXPECT_FALSE(fail_next_iteration.load()) << "no iteration was handed over";
  EXPECT_TRUE(document->settled());
  const cli::Document::AnswerFailure failure = document->answer_failure();
  EXPECT_EQ(failure.request, document->last_published_request());  // the paper's update, published before
  EXPECT_FALSE(document->refinement().finished);
  {
    const std::lock_guard lock(mutex);
    ASSERT_FALSE(woken_with.empty());
    EXPECT_EQ(woken_with.back(), failure.why) << "the window was not woken with the failure";
  }
  // New poses: refined to the end, and no failure left.
  document->set_pose(0, Eigen::Vector3d::UnitX(), 0.0, 1.0, Eigen::Vector3d(0.0, -0.25, 0.0));
  document->commit();
  EXPECT_NO_THROW((void)document->result());
  EXPECT_TRUE(document->answer_failure().why.empty());
  EXPECT_TRUE(document->settled());
  EXPECT_TRUE(document->refinement().finished);
  // The same poses failing again, then refinement off: the paper's update alone, no failure.
  document->set_pose(0, Eigen::Vector3d::UnitX(), 0.0, 1.0, Eigen::Vector3d(0.0, -0.2, 0.0));
  fail_next_iteration = true;
  document->commit();
  EXPECT_THROW((void)document->result(), SolveError);
  document->set_refine(false);
  document->commit();
  const Eigen::MatrixXd unrefined = document->result();
  EXPECT_TRUE(document->answer_failure().why.empty());
  Deformer paper(shape.mesh, shape.demo_constraints);
  Eigen::MatrixXd expected;
  const HandleTransform pose = document->pose(0);
  paper.deform(std::span(&pose, 1), expected);
  EXPECT_LT((unrefined - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_F(DocumentTest, AFailedSetUpKeepsThePreviousResultOnScreen) {
  document->paint(shape.demo_constraints.fixed, cli::Layer::Fixed, false);
  document->paint(shape.demo_constraints.handles[0], cli::Layer::Handle, false);
  document->set_pose(0, Eigen::Vector3d::UnitX(), 0.8, 1.0, Eigen::Vector3d::Zero());
  document->commit();
  const Eigen::MatrixXd shown = document->result();
  for (int k = 0; k < 200 && publications.load() == 0; ++k) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_GT(publications.load(), 0);
  const int published = publications.load();
  // Without a fixed vertex the system is singular: the set-up fails with the reason, and nothing
  // replaces what the screen shows.
  document->clear(cli::Layer::Fixed);
  document->commit();
  document->wait_until_ready();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Failed);
  EXPECT_FALSE(document->solver_message().empty());
  document->set_pose(0, Eigen::Vector3d::UnitX(), 1.4, 1.0, Eigen::Vector3d::Zero());
  document->commit();
  EXPECT_EQ(document->request_update(), 0u);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(publications.load(), published);
  EXPECT_THROW((void)document->result(), SolveError);
  // Undo brings the solvable state and its result back.
  ASSERT_TRUE(document->undo());
  ASSERT_TRUE(document->undo());
  document->wait_until_ready();
  EXPECT_EQ(document->solver_state(), cli::Document::SolverState::Ready);
  EXPECT_EQ(document->result(), shown);
}

TEST(Recovery, ThePromptSaysWhatTheFileHoldsAndWhen) {
  cli::Session session;
  session.mesh = "/meshes/cactus.obj";
  EXPECT_EQ(cli::describe_session(session), "no handle, 0 fixed vertices");
  session.current.fixed = {1, 2, 3};
  session.current.handles.push_back({{4}, HandleTransform{}});
  EXPECT_EQ(cli::describe_session(session), "1 handle (1 vertex, at rest), 3 fixed vertices");
  session.current.handles[0].transform = HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero(), 0.0, 1.0, Eigen::Vector3d(0.1, 0.0, 0.0));
  session.current.handles.push_back({{5, 6}, HandleTransform{}});
  session.current.region_of_interest = {1, 2, 3, 4, 5, 6, 7};
  session.applied.push_back(session.current);
  EXPECT_EQ(cli::describe_session(session),
            "handle 1 (1 vertex, moved), handle 2 (2 vertices, at rest), 3 fixed vertices, a region of interest of 7 vertices, 1 applied stage");
  cli::Session many = session;  // beyond three handles, the rest counted
  many.current.handles.push_back({{8}, HandleTransform{}});
  many.current.handles.push_back({{9}, HandleTransform{}});
  EXPECT_TRUE(cli::describe_session(many).find("handle 3 (1 vertex, at rest), 1 more handle, 3 fixed vertices") != std::string::npos)
      << cli::describe_session(many);

  const auto now = std::filesystem::file_time_type::clock::now();
  EXPECT_TRUE(cli::describe_age(now - std::chrono::seconds(20), now).ends_with(", less than a minute ago"));
  EXPECT_TRUE(cli::describe_age(now - std::chrono::minutes(12), now).ends_with(", 12 minutes ago"));
  EXPECT_TRUE(cli::describe_age(now - std::chrono::hours(5), now).ends_with(", 5 hours ago"));
  const std::string days = cli::describe_age(now - std::chrono::hours(24 * 3), now);
  EXPECT_TRUE(days.ends_with(", 3 days ago")) << days;
  EXPECT_EQ(days.substr(4, 1), "-") << "older than a day: the date too (" << days << ")";

  test::TempDir dir;
  const auto recovery = dir.file("recovery.json");
  cli::write_session(recovery, session);
  const cli::RestoreOffer same = cli::make_restore_offer(recovery, dir.file("none-transfer.json"), "/meshes/cactus.obj");
  EXPECT_EQ(same.mesh, session.mesh);
  EXPECT_FALSE(same.conflicts());
  EXPECT_TRUE(same.written.ends_with("less than a minute ago"));
  EXPECT_FALSE(cli::make_restore_offer(recovery, dir.file("none-transfer.json"), "").conflicts());
  EXPECT_TRUE(cli::make_restore_offer(recovery, dir.file("none-transfer.json"), "/meshes/bar.obj").conflicts());
  EXPECT_TRUE(cli::make_restore_offer(recovery, dir.file("none-transfer.json"), "shape:bar").conflicts());

  // Set aside, it keeps its contents under a new name, and a second one does not overwrite it.
  const auto first = cli::set_recovery_aside(recovery);
  EXPECT_FALSE(std::filesystem::exists(recovery));
  EXPECT_EQ(cli::read_session(first), session);
  cli::write_session(recovery, cli::Session{"shape:bar", {}, {}, 0});
  std::filesystem::last_write_time(recovery, std::filesystem::last_write_time(first));  // the same second
  const auto second = cli::set_recovery_aside(recovery);
  EXPECT_NE(second, first);
  EXPECT_EQ(cli::read_session(first), session);
  EXPECT_EQ(cli::read_session(second).mesh, "shape:bar");
  EXPECT_EQ(first.parent_path(), recovery.parent_path());

  std::ofstream(recovery) << "{ not json";
  EXPECT_THROW(cli::make_restore_offer(recovery, dir.file("none-transfer.json"), ""), InputError);
  std::filesystem::remove(recovery);
  EXPECT_THROW(cli::make_restore_offer(recovery, dir.file("none-transfer.json"), ""), InputError) << "no recovery file at all";
}

// Transfer mode's recovery: every field comes back, a broken file is refused naming the file and
// the field, and the prompt says what it holds; with only that file, the offer is transfer mode's.
TEST(Recovery, TransferModeStateRoundTripsAndIsOffered) {
  test::TempDir dir;
  cli::TransferState state;
  state.source_rest = "/meshes/horse-ref.obj";
  state.target = "/meshes/camel-ref.obj";
  state.poses = {"/meshes/horse-01.obj", "/meshes/horse-02.obj"};
  state.markers_file = "/meshes/markers.txt";
  state.source_column = 2;
  state.markers.source = {3, 1, 4};
  state.markers.target = {1, 5, 9};
  state.source_y_up = true;
  state.method = 1;
  state.top_n = 5;
  state.mismatch_threshold = 0.15;
  const auto path = dir.file("recovery-transfer.json");
  cli::write_transfer_state(path, state);
  EXPECT_EQ(cli::read_transfer_state(path), state);
  EXPECT_EQ(cli::describe_transfer_state(state), "horse-ref.obj -> camel-ref.obj, 2 poses, 3 marker pairs");

  const cli::RestoreOffer offer = cli::make_restore_offer(dir.file("recovery.json"), path, "shape:bar");
  EXPECT_TRUE(offer.recovery.empty());
  EXPECT_EQ(offer.transfer_recovery, path);
  EXPECT_EQ(offer.transfer, cli::describe_transfer_state(state));
  EXPECT_FALSE(offer.conflicts()) << "no edit session to restore instead of the requested mesh";

  const auto broken = [&](const std::string& text) {
    std::ofstream(path) << text;
    try {
      cli::read_transfer_state(path);
    } catch (const InputError& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  nlohmann::json json = nlohmann::json::parse(std::ifstream(path));
  json["marker_target"] = {1, 5};
  EXPECT_EQ(broken(json.dump()), path.string() + ": \"marker_source\" and \"marker_target\" differ in length");
  json["marker_target"] = {1, 5, -9};
  EXPECT_EQ(broken(json.dump()), path.string() + ": negative marker vertex -9");
  json.erase("marker_target");
  EXPECT_EQ(broken(json.dump()), path.string() + ": \"marker_target\" is missing");
  EXPECT_EQ(broken("{\"hdeform_transfer_state\": 1, \"source_rest\": 7}"), path.string() + ": \"source_rest\" has the wrong type");
  EXPECT_TRUE(broken("[1, 2").starts_with(path.string() + ": not JSON"));
}

// The editor's live figures against a timeline worked out by hand.
TEST(FrameStatistics, LatencyRunsFromEachInputToTheFirstFinishedFrameShowingItsSolve) {
  using namespace std::chrono_literals;
  cli::FrameStatistics statistics;
  const auto t0 = cli::FrameStatistics::Clock::now();
  const cli::FrameStatistics::Clock::time_point first[] = {t0, t0 + 5ms};
  const cli::FrameStatistics::Clock::time_point second[] = {t0 + 10ms};
  statistics.note_request(1, first);
  statistics.note_request(2, second);
  statistics.note_submitted(1, 0, true, t0 + 12ms);  // after an idle wait: no interval
  statistics.note_submitted(2, 1, false, t0 + 20ms);
  statistics.note_submitted(3, 2, false, t0 + 30ms);
  statistics.note_finished(1, t0 + 15ms);
  EXPECT_TRUE(statistics.latencies().empty()) << "frame 1 shows no solve yet";
  EXPECT_TRUE(statistics.frame_intervals().empty());
  statistics.note_finished(2, t0 + 25ms);
  statistics.note_finished(3, t0 + 40ms);
  EXPECT_EQ(statistics.latencies(), (std::vector<double>{25.0, 20.0, 30.0}));
  EXPECT_EQ(statistics.frame_intervals(), (std::vector<double>{10.0, 15.0}));
  EXPECT_EQ(statistics.frames_per_second(t0 + 40ms), 3u);
  EXPECT_EQ(statistics.frames_per_second(t0 + 1025ms), 1u);
  EXPECT_EQ(statistics.recent_update_ms(7.0), 7.0);
  for (int k = 1; k <= 30; ++k) statistics.note_update(k);
  EXPECT_EQ(statistics.recent_update_ms(7.0), 21.0);  // the median of the last 20: 11..30
  statistics.restart();
  EXPECT_TRUE(statistics.latencies().empty());
  EXPECT_TRUE(statistics.frame_intervals().empty());
}

// A benchmark's report covers its whole run: at 40 frames per second a 30-second drag has 1,200
// frames, twice what the live window keeps (its figures once counted only the last 600).
TEST(FrameStatistics, ARestartRecordsEveryFrameAndLatencyBeyondTheLiveWindow) {
  using namespace std::chrono_literals;
  cli::FrameStatistics statistics;
  const auto t0 = cli::FrameStatistics::Clock::now();
  const cli::FrameStatistics::Clock::time_point before[] = {t0};
  statistics.note_request(1, before);
  statistics.note_submitted(1, 1, false, t0);
  statistics.note_submitted(2, 1, false, t0 + 1ms);
  statistics.note_finished(1, t0 + 2ms);
  statistics.note_finished(2, t0 + 3ms);
  EXPECT_TRUE(statistics.recorded_frame_intervals().empty()) << "nothing is recorded before a restart";
  EXPECT_TRUE(statistics.recorded_latencies().empty());
  statistics.restart();
  constexpr int kFrames = 1500;
  for (int k = 1; k <= kFrames; ++k) {
    const auto at = t0 + std::chrono::milliseconds(25 * k);
    const cli::FrameStatistics::Clock::time_point input[] = {at - 5ms, at - 1ms};
    statistics.note_request(static_cast<std::uint64_t>(k + 1), input);
    statistics.note_submitted(static_cast<std::uint64_t>(k + 2), static_cast<std::uint64_t>(k + 1), false, at);
    statistics.note_finished(static_cast<std::uint64_t>(k + 2), at + 10ms);
  }
  // The first frame after the restart has no interval (nothing finished before it since).
  ASSERT_EQ(statistics.recorded_frame_intervals().size(), static_cast<std::size_t>(kFrames - 1));
  EXPECT_TRUE(std::all_of(statistics.recorded_frame_intervals().begin(), statistics.recorded_frame_intervals().end(),
                          [](double ms) { return std::abs(ms - 25.0) < 1e-9; }));
  ASSERT_EQ(statistics.recorded_latencies().size(), static_cast<std::size_t>(2 * kFrames));
  EXPECT_NEAR(statistics.recorded_latencies()[0], 15.0, 1e-9);
  EXPECT_NEAR(statistics.recorded_latencies()[1], 11.0, 1e-9);
  EXPECT_LT(statistics.frame_intervals().size(), statistics.recorded_frame_intervals().size()) << "the live window stays short";
  statistics.restart();
  EXPECT_TRUE(statistics.recorded_frame_intervals().empty());
  EXPECT_TRUE(statistics.recorded_latencies().empty());
}

TEST(SyntheticDrag, MovesComeInOrderAndThePoseGoesToTheTargetAndBackEveryTwoSeconds) {
  const HandleTransform target = HandleTransform::about_pivot(Eigen::Vector3d::UnitX(), Eigen::Vector3d(0.1, 0.2, 0.3), 0.5, 1.0, Eigen::Vector3d(0, 0.4, 0));
  EXPECT_TRUE(cli::SyntheticDrag::pose_at(target, 0.0).is_identity());
  EXPECT_NEAR(cli::SyntheticDrag::pose_at(target, 1.0).angle, target.angle, 1e-12);
  EXPECT_NEAR((cli::SyntheticDrag::pose_at(target, 1.0).shift - target.shift).norm(), 0.0, 1e-12);
  EXPECT_NEAR(cli::SyntheticDrag::pose_at(target, 2.0).angle, 0.0, 1e-12);
  EXPECT_NEAR(cli::SyntheticDrag::pose_at(target, 0.5).angle, 0.5 * target.angle, 1e-12);
  std::atomic<int> wakes{0};
  std::vector<cli::SyntheticDrag::Clock::time_point> moves;
  {
    cli::SyntheticDrag drag([&] { ++wakes; });
    std::this_thread::sleep_for(std::chrono::milliseconds(120));
    moves = drag.take();
    drag.stop();
    EXPECT_GE(moves.size(), 3u);
    EXPECT_TRUE(std::is_sorted(moves.begin(), moves.end()));
    EXPECT_GE(moves.front(), drag.started());
  }
  EXPECT_GE(wakes.load(), static_cast<int>(moves.size()));
}

TEST(RecentFiles, NewestFirstOnceEachAtMostTenOnlyWhatExistsAndKeptAcrossStarts) {
  test::TempDir dir;
  std::vector<std::string> files;
  for (int k = 0; k < 12; ++k) {
    files.push_back(dir.file("mesh-" + std::to_string(k) + ".obj").string());
    std::ofstream(files.back()) << "v 0 0 0\n";
  }
  const auto list_path = dir.file("state/recent.json");
  {
    cli::RecentFiles recent(list_path);
    EXPECT_TRUE(recent.list().empty());
    recent.add(files[0]);
    recent.add(files[1]);
    recent.add(files[0]);  // again: first, once
    EXPECT_EQ(recent.list(), (std::vector<std::string>{files[0], files[1]}));
    for (const auto& file : files) recent.add(file);
    EXPECT_EQ(recent.list().size(), cli::RecentFiles::kKept);
    EXPECT_EQ(recent.list().front(), files.back());
  }
  std::filesystem::remove(files.back());
  const cli::RecentFiles again(list_path);
  EXPECT_EQ(again.list().size(), cli::RecentFiles::kKept - 1) << "a file since removed is not offered";
  EXPECT_EQ(again.list().front(), files[10]);
  std::ofstream(list_path) << "{ broken";
  EXPECT_TRUE(cli::RecentFiles(list_path).list().empty()) << "an unreadable list is an empty one";
}

TEST(MarkerEditor, PairsAddMoveRemoveWithUndoAndOneMarkerPerVertex) {
  cli::MarkerEditor markers;
  EXPECT_FALSE(markers.add(10, 20).has_value());
  EXPECT_FALSE(markers.add(11, 21).has_value());
  const auto taken = markers.add(10, 30);
  ASSERT_TRUE(taken.has_value());
  EXPECT_EQ(*taken, "source vertex 10 already has marker 1");
  EXPECT_EQ(*markers.add(12, 21), "target vertex 21 already has marker 2");
  EXPECT_EQ(markers.size(), 2u);
  EXPECT_EQ(markers.find(cli::MarkerSide::Target, 21), 1);

  EXPECT_FALSE(markers.move(0, cli::MarkerSide::Target, 25).has_value());
  EXPECT_EQ(markers.pairs().target, (std::vector<int>{25, 21}));
  EXPECT_EQ(*markers.move(0, cli::MarkerSide::Target, 21), "target vertex 21 already has marker 2");
  EXPECT_FALSE(markers.move(0, cli::MarkerSide::Target, 25).has_value());  // onto itself: nothing to do
  markers.remove(1);
  EXPECT_EQ(markers.pairs().source, (std::vector<int>{10}));

  const auto version = markers.version();
  ASSERT_TRUE(markers.undo());  // the removal
  EXPECT_EQ(markers.pairs().source, (std::vector<int>{10, 11}));
  ASSERT_TRUE(markers.undo());  // the move
  EXPECT_EQ(markers.pairs().target, (std::vector<int>{20, 21}));
  EXPECT_NE(markers.version(), version);  // results computed before are stale
  ASSERT_TRUE(markers.redo());
  EXPECT_EQ(markers.pairs().target, (std::vector<int>{25, 21}));
  // A new change after undo drops the redo branch.
  EXPECT_FALSE(markers.add(13, 23).has_value());
  EXPECT_FALSE(markers.can_redo());
  while (markers.undo()) {
  }
  EXPECT_EQ(markers.size(), 0u);
}

}  // namespace
}  // namespace hdeform

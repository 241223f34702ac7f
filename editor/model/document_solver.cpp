// The document's solver side: the set-up on a worker thread (its progress, and its abandonment
// once the selection moves on), its installation with the drag pipeline, and the updates asked of
// it. The editing side (painting, handles, poses, history) is document.cpp.
#include <algorithm>
#include <new>

#include "document.h"
#include "document_parts.h"
#include "hdeform/errors.h"

namespace hdeform::cli {
namespace {

// Thrown from a set-up's progress report once the set-up is of no use any more.
struct SetUpStopped {};

// Whether a set-up with `choice` can take `operators` (the Deformer checks the resolution, not the
// base's size).
bool operators_fit(const MeshOperators& operators, const Document::SolveChoice& choice) {
  if (operators.resolution() != choice.resolution) return false;
  return !operators.multiresolution || operators.multiresolution->requested_vertices == choice.base_vertices;
}

}  // namespace

Document::~Document() {
  stop_pipeline();
  if (build_) {
    // Closing or opening another mesh: nothing of it is wanted, and nobody waits for the stage
    // in progress to end.
    build_->progress->stop = true;
    build_->task.abandon();
  }
}

Document::SolverState Document::solver_state() const {
  if (build_) return SolverState::Building;
  if (!failure_.empty()) return SolverState::Failed;
  if (deformer_) return SolverState::Ready;
  return SolverState::NoHandle;
}

std::string Document::solver_message() const {
  if (build_) {
    std::lock_guard lock(build_->progress->mutex);
    return build_->progress->stage;
  }
  return failure_;
}

const Eigen::VectorXd* Document::field() const { return deformer_ ? &deformer_->field() : nullptr; }
const DeformerTimings* Document::setup_timings() const { return deformer_ ? &deformer_->timings() : nullptr; }
Eigen::Index Document::solved_vertex_count() const { return deformer_ ? deformer_->solved_mesh().vertex_count() : 0; }
SparseCholesky::Refinement Document::factor_refinement() const {
  return deformer_ ? deformer_->system().factor().refinement() : SparseCholesky::Refinement{};
}
FactorPrecision Document::factor_precision() const { return deformer_ ? deformer_->system().factor().precision() : options_.precision; }
std::vector<std::string> Document::warnings() const { return deformer_ ? deformer_->warnings() : std::vector<std::string>{}; }

void Document::set_options(const DeformerOptions& options) {
  const DeformerOptions decided = options_;
  options_ = options;
  // Where the session solves is part of it (decided when it opened).
  options_.resolution = decided.resolution;
  options_.base_vertices = decided.base_vertices;
  options_.precision = decided.precision;
  stop_pipeline();
  deformer_.reset();
  failure_.clear();
}

void Document::set_solve_choice(const SolveChoice& choice) {
  if (!can_change_solve_choice()) throw std::logic_error("Document: where a session with applied stages solves cannot change");
  if (choice.resolution == Resolution::Automatic) throw std::invalid_argument("Document: a solve choice is Exact or Multiresolution");
  if (choice.base_vertices < 4) throw std::invalid_argument("Document: a base mesh needs at least 4 vertices");
  options_.resolution = choice.resolution;
  options_.base_vertices = choice.base_vertices;
  options_.precision = choice.precision;
}

void Document::stop_pipeline() {
  pipeline_.reset();  // waits for the update in flight
}

void Document::start_build() {
  build_ = std::make_unique<Build>();
  build_->constraints = current_stage().constraints();
  build_->rest = rest_;
  build_->choice = solve_choice();
  // A new selection on the same rest shape reuses its weights and Laplacian.
  if (operators_rest_ == rest_ && operators_ && operators_fit(*operators_, build_->choice)) build_->operators = operators_;
  DeformerOptions options = options_;
  options.prepare_refinement = refine_;  // set up with the rest, off the frame loop
  options.refinement = current_stage().refinement_options();
  build_->task.start("set-up", [rest = build_->rest, constraints = build_->constraints, operators = build_->operators, options,
                                progress = build_->progress] {
    return std::make_unique<Deformer>(rest, constraints, operators, options, [progress](std::string_view stage) {
      if (progress->stop.load()) throw SetUpStopped{};
      std::lock_guard lock(progress->mutex);
      progress->stage = std::string(stage);
    });
  });
}

bool Document::set_up_reuses_operators() const { return build_ && build_->operators; }

void Document::install_build() {
  auto outcome = build_->task.take();
  std::unique_ptr<Build> build = std::move(build_);
  const bool still_current =
      build->constraints == current_stage().constraints() && build->rest == rest_ && build->choice == solve_choice();
  if (!still_current) {
    if (outcome.exception && build->progress->stop.load()) {
      try {
        std::rethrow_exception(outcome.exception);
      } catch (const SetUpStopped&) {
        ++set_ups_stopped_;
      } catch (...) {  // it failed on its own before it could stop: nothing to keep either way
      }
    }
    // The next poll starts a build for the new constraints. What depends on the rest shape alone
    // (at 13M triangles the base mesh, 22 s of the set-up's 25) serves it as well, where the
    // session still solves that way.
    if (outcome.result && build->rest == rest_ && operators_fit(*(*outcome.result)->operators(), solve_choice())) {
      operators_ = (*outcome.result)->operators();
      operators_rest_ = build->rest;
    }
    return;
  }
  if (outcome.exception) {
    try {
      std::rethrow_exception(outcome.exception);
    } catch (const std::bad_alloc&) {
      failure_ = "out of memory while setting up the solve (a smaller region of interest needs less)";
    } catch (const std::exception& error) {
      failure_ = error.what();
    }
    stop_pipeline();
    deformer_.reset();
    deformer_constraints_ = build->constraints;
    deformer_rest_ = rest_.get();
    deformer_choice_ = build->choice;
    return;
  }
  failure_.clear();
  stop_pipeline();
  deformer_ = std::move(*outcome.result);
  operators_ = deformer_->operators();
  operators_rest_ = build->rest;
  deformer_constraints_ = build->constraints;
  deformer_rest_ = rest_.get();
  deformer_choice_ = build->choice;
  request_base_ = last_request_.load();
  const std::uint64_t base = request_base_;
  pipeline_ = std::make_unique<UpdatePipeline>(*deformer_, [this, base](const UpdatePipeline::Result& result) {
    if (result.refinement.iterations == 0 && !result.completion) last_update_ms_ = result.update_ms;
    const bool finished = result.refinement.converged || (result.refinement.iterations > 0 &&
                                                          result.refinement.iterations >= deformer_->refinement_options().max_iterations);
    // The positions go out first: once the view below says a refinement has finished (settled()),
    // its positions are the ones published.
    if (publish_) {
      const Answer answer = result.partial                      ? Answer::Partial
                            : result.refinement.iterations == 0 ? Answer::Whole
                            : finished                          ? Answer::Refined
                                                                : Answer::Settling;
      publish_(result.positions, base + result.request, answer);
    }
    {
      // The deformer's timings are its last update's or iteration's: this thread just ran it.
      std::lock_guard lock(refinement_mutex_);
      refinement_ = result.refinement;
      refinement_ms_ = result.refinement.iterations > 0 ? result.update_ms : 0.0;
      refinement_request_ = base + result.request;
      refinement_finished_ = finished;
      refinement_digest_.clear();
      constexpr std::size_t kKept = 512;
      if (result.completion) {
        // The rest of a partial answer's vertices: no update of its own to time.
      } else if (result.refinement.iterations == 0) {
        if (update_timings_.size() < kKept) update_timings_.push_back(deformer_->last_update());
      } else if (refinement_timings_.size() < kKept) {
        refinement_timings_.push_back(deformer_->refinement_timings());
      }
    }
    last_published_ = base + result.request;
    if (wake_) wake_();
    if (finished) {
      // Digested after settled() says so, for the window draws the shape whole without it: at 3.3
      // million triangles the digest took about 67 ms in a trace (0.15 s at 13 million). Outside
      // the lock, which the window's frame takes. This thread alone writes the view, so it still
      // answers this publication.
      std::string digest = positions_digest(result.positions);
      {
        std::lock_guard lock(refinement_mutex_);
        refinement_digest_ = std::move(digest);
      }
      if (wake_) wake_();
    }
  }, [this, base](const UpdatePipeline::Failure& failure) {
    std::string why = failure.refining ? "The refinement stopped: " : "These poses could not be solved: ";
    try {
      std::rethrow_exception(failure.error);
    } catch (const std::bad_alloc&) {
      why += "out of memory";
    } catch (const std::exception& error) {
      why += error.what();
    } catch (...) {
      why += "an unknown error";
    }
    why += failure.refining ? ". The shape shown is the last one it reached; new poses, or Refine off, solve again."
                            : ". The shape shown is the last one solved; new poses solve again.";
    {
      std::lock_guard lock(refinement_mutex_);
      failed_request_ = base + failure.request;
      answer_failure_ = std::move(why);
    }
    if (wake_) wake_();
  });
  pipeline_->set_refinement(refine_);
  pipeline_->set_refinement_delay(refinement_delay_);
  pipeline_->set_refinement_publication_interval(publication_interval_);
  request_update();
}

void Document::poll() {
  if (build_ && build_->task.done()) install_build();
  // A set-up for another rest shape or solve choice would leave nothing of use (a selection's
  // would leave its operators): it stops at its next stage, so that an undone switch to every
  // vertex of a scan does not hold up the set-up after it for the rest of a long factorization.
  if (build_ && (build_->rest != rest_ || !(build_->choice == solve_choice()))) build_->progress->stop = true;
  if (build_ || hold_set_up_) return;
  const EditConstraints constraints = current_stage().constraints();
  if (constraints.handles.empty()) {
    stop_pipeline();
    deformer_.reset();
    failure_.clear();
    return;
  }
  if (deformer_is_current(constraints) && (deformer_ || !failure_.empty())) return;
  failure_.clear();
  start_build();
}

bool Document::deformer_is_current(const EditConstraints& constraints) const {
  return constraints == deformer_constraints_ && deformer_rest_ == rest_.get() && deformer_choice_ == solve_choice();
}

bool Document::previous_selection_answers(const EditStage& stage) const {
  return build_ && pipeline_ && deformer_ && deformer_rest_ == rest_.get() && deformer_->handle_count() == stage.handles.size();
}

bool Document::drags_previous_selection() const {
  const EditStage stage = current_stage();
  return previous_selection_answers(stage) && !deformer_is_current(stage.constraints());
}

std::uint64_t Document::request_update(bool partial) {
  if (!pipeline_ || !deformer_) return 0;
  // Built once: the drag calls this for every move. While a new selection is being factored the
  // drag goes on with the last one (same rest shape, as many non-empty handles); installing the
  // new set-up solves the current poses again.
  const EditStage stage = current_stage();
  if (deformer_constraints_ != stage.constraints() && !previous_selection_answers(stage)) return 0;
  last_request_ = request_base_ + pipeline_->submit(stage.transforms(), partial ? partial_vertices_ : nullptr);
  submitted_ = stage;
  return last_request_.load();
}

bool Document::settled() const {
  if (build_) return false;
  const EditStage stage = current_stage();
  if (stage.handles.empty() || !deformer_) return true;  // the rest shape, or a failure: nothing to wait for
  if (!pipeline_ || !submitted_ || !(*submitted_ == stage)) return false;
  if (!answer_failure().why.empty()) return true;
  if (last_published_.load() != last_request_.load()) return false;
  if (!refine_) return true;
  const RefinementView view = refinement();
  return view.request == last_request_.load() && view.finished;
}

void Document::close() {
  stop_pipeline();
  if (build_) build_->progress->stop = true;
}

void Document::wait_until_ready() {
  hold_set_up_ = false;  // the answer is wanted now
  for (;;) {
    poll();
    if (!build_) return;
    build_->task.wait();
  }
}

Eigen::MatrixXd Document::result() {
  wait_until_ready();
  const EditStage stage = current_stage();
  if (stage.handles.empty()) return rest_->positions;
  if (!deformer_) throw SolveError(failure_.empty() ? "the deformation could not be set up" : failure_);
  // The pipeline's answer to these poses: each of its edits starts from the paper's result and
  // stops where the stage's refinement_options() say, as stage_result() does.
  if (!submitted_ || !(*submitted_ == stage)) request_update();
  Eigen::MatrixXd positions = pipeline_->settled_positions();
  // Recorded before the pipeline said it was idle.
  if (AnswerFailure failure = answer_failure(); !failure.why.empty()) throw SolveError(failure.why);
  return positions;
}

Document::AnswerFailure Document::answer_failure() const {
  std::lock_guard lock(refinement_mutex_);
  if (failed_request_ == 0 || failed_request_ != last_request_.load()) return {};
  return {failed_request_, answer_failure_};
}

void Document::set_refinement_delay(std::chrono::milliseconds delay) {
  if (delay == refinement_delay_) return;
  refinement_delay_ = delay;
  if (pipeline_) pipeline_->set_refinement_delay(delay);
}

void Document::set_refinement_publication_interval(std::chrono::milliseconds interval) {
  if (interval == publication_interval_) return;
  publication_interval_ = interval;
  if (pipeline_) pipeline_->set_refinement_publication_interval(interval);
}

void Document::set_refine(bool on) {
  refine_ = on;
  if (pipeline_) pipeline_->set_refinement(on);
}

std::vector<UpdateTimings> Document::take_update_timings() {
  std::lock_guard lock(refinement_mutex_);
  std::vector<UpdateTimings> taken;
  taken.swap(update_timings_);
  return taken;
}

std::vector<RefinementTimings> Document::take_refinement_timings() {
  std::lock_guard lock(refinement_mutex_);
  std::vector<RefinementTimings> taken;
  taken.swap(refinement_timings_);
  return taken;
}

Document::RefinementView Document::refinement() const {
  std::lock_guard lock(refinement_mutex_);
  return {refinement_, refinement_ms_, refinement_request_, refinement_digest_, refinement_finished_};
}

}  // namespace hdeform::cli

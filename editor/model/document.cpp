#include "document.h"

#include <algorithm>
#include <limits>
#include <new>

#include "background_task.h"
#include "hdeform/errors.h"

namespace hdeform::cli {
namespace {

constexpr std::size_t kHistoryLimit = 200;

bool same_constraints(const EditConstraints& a, const EditConstraints& b) {
  return a.fixed == b.fixed && a.handles == b.handles && a.region_of_interest == b.region_of_interest;
}

// Thrown from a set-up's progress report once the set-up is of no use any more.
struct SetUpStopped {};

// Whether a set-up with `choice` can take `operators` (the Deformer checks the resolution, not the
// base's size).
bool operators_fit(const MeshOperators& operators, const Document::SolveChoice& choice) {
  if (operators.resolution() != choice.resolution) return false;
  return !operators.multiresolution || operators.multiresolution->requested_vertices == choice.base_vertices;
}

}  // namespace

struct Document::Build {
  EditConstraints constraints;
  std::shared_ptr<const Mesh> rest;
  SolveChoice choice;
  std::shared_ptr<const MeshOperators> operators;  // of `rest`, from the last set-up on it, or null
  // Shared with the set-up's thread, which an abandoned set-up keeps to its next stage.
  struct Progress {
    std::atomic<bool> stop{false};  // set once the set-up cannot serve: it stops at its next stage
    std::mutex mutex;
    std::string stage;  // with mutex: the set-up's current stage, for the panel
  };
  std::shared_ptr<Progress> progress = std::make_shared<Progress>();
  BackgroundTask<std::unique_ptr<Deformer>> task;
};

Document::Document(Session session, Mesh base, DeformerOptions options, Publish publish)
    : mesh_name_(session.mesh), applied_(session.applied), options_(options), publish_(std::move(publish)) {
  check_session_against_mesh(session, base.vertex_count(), SessionSource{"session", {}});
  // Where this session solves, decided once: a session that says keeps it, so that every stage,
  // the saved file and its replay solve alike.
  if (session.resolution != Resolution::Automatic) {
    options_.resolution = session.resolution;
    options_.base_vertices = session.base_vertices;
  } else {
    options_.resolution = resolution_for(base.vertex_count(), options_.resolution);
  }
  session.resolution = options_.resolution;
  session.base_vertices = options_.base_vertices;
  if (session.precision) options_.precision = *session.precision;
  session.precision = options_.precision;
  // The mesh is moved, not copied: at 3.3 million triangles each copy is 79 MB of fresh pages,
  // whose first writes cost this kind of host 0.2-0.3 s.
  validate_mesh(base, session.mesh.empty() ? "session mesh" : session.mesh);
  auto rest = std::make_shared<Mesh>(std::move(base));
  if (!session.applied.empty()) {
    Session applied_only = session;
    applied_only.current = {};
    rest->positions = replay_session(applied_only, *rest, options_);
  }
  rest_ = std::move(rest);
  load_stage(session.current);
  active_handle_ = handles_.empty() ? 0 : std::clamp(session.active_handle, 0, static_cast<int>(handles_.size()) - 1);
  history_.push_back({this->session(), rest_, "open"});
  // The set-up starts now, on the loading thread's time, rather than at the first poll: the
  // editor still has the mesh to hand to the renderer (at 13 million triangles, seconds).
  poll();
}

Document::~Document() {
  stop_pipeline();
  if (build_) {
    // Closing or opening another mesh: nothing of it is wanted, and nobody waits for the stage
    // in progress to end.
    build_->progress->stop = true;
    build_->task.abandon();
  }
}

struct Document::AdjacencyBuild {
  BackgroundTask<VertexAdjacency> task;
};

// Not made with the document: at 3.3 million triangles it took 0.43 s of opening, before the
// set-up could start, and only growing, shrinking and picking a connected part need it. The
// triangles never change, so one adjacency serves every rest shape.
const VertexAdjacency& Document::adjacency() const {
  if (!adjacency_ && adjacency_build_) {
    auto outcome = adjacency_build_->task.take();  // waits, if it is still being built
    adjacency_build_.reset();
    if (outcome.result) adjacency_.emplace(std::move(*outcome.result));
  }
  if (!adjacency_) adjacency_.emplace(rest_->triangles, rest_->vertex_count());
  return *adjacency_;
}

void Document::prepare_adjacency() {
  if (adjacency_ || adjacency_build_) return;
  adjacency_build_ = std::make_unique<AdjacencyBuild>();
  adjacency_build_->task.start("adjacency", [rest = rest_] { return VertexAdjacency(rest->triangles, rest->vertex_count()); });
}

const Document::PaintedLists& Document::painted() const {
  if (painted_.version == painted_version_) return painted_;
  PaintedLists lists;
  lists.handles.resize(handles_.size());
  for (std::size_t v = 0; v < labels_.size(); ++v) {
    if (roi_[v]) lists.region_of_interest.push_back(static_cast<int>(v));
    if (labels_[v] == kFixed) lists.fixed.push_back(static_cast<int>(v));
    if (labels_[v] >= 0) lists.handles[static_cast<std::size_t>(labels_[v])].push_back(static_cast<int>(v));
  }
  lists.version = painted_version_;
  painted_ = std::move(lists);
  return painted_;
}

EditStage Document::current_stage() const {
  EditStage stage;
  const PaintedLists& lists = painted();
  stage.region_of_interest = lists.region_of_interest;
  stage.fixed = lists.fixed;
  for (std::size_t h = 0; h < handles_.size(); ++h) {
    if (!lists.handles[h].empty()) stage.handles.push_back({lists.handles[h], handles_[h].transform});
  }
  stage.refine = refine_;
  stage.refine_settle = refine_settle_;
  return stage;
}

Session Document::session() const {
  Session session;
  session.mesh = mesh_name_;
  session.applied = applied_;
  session.current = current_stage();
  // The active handle among the non-empty ones.
  int active = 0;
  for (int h = 0; h < active_handle_ && h < static_cast<int>(handle_sizes_.size()); ++h) active += handle_sizes_[static_cast<std::size_t>(h)] > 0 ? 1 : 0;
  session.active_handle = session.current.handles.empty() ? 0 : std::min(active, static_cast<int>(session.current.handles.size()) - 1);
  session.resolution = options_.resolution;
  session.base_vertices = options_.base_vertices;
  session.precision = options_.precision;
  return session;
}

void Document::load_stage(const EditStage& stage) {
  ++painted_version_;
  const auto n = static_cast<std::size_t>(rest_->vertex_count());
  labels_.assign(n, kFree);
  roi_.assign(n, false);
  roi_count_ = stage.region_of_interest.size();
  for (const int v : stage.region_of_interest) roi_[static_cast<std::size_t>(v)] = true;
  for (const int v : stage.fixed) labels_[static_cast<std::size_t>(v)] = kFixed;
  handles_.clear();
  handle_sizes_.clear();
  for (std::size_t h = 0; h < stage.handles.size(); ++h) {
    for (const int v : stage.handles[h].vertices) labels_[static_cast<std::size_t>(v)] = static_cast<int>(h);
    handles_.push_back({stage.handles[h].transform});
    handle_sizes_.push_back(stage.handles[h].vertices.size());
  }
  set_refine(stage.refine);
  if (stage.refine_settle != refine_settle_) {
    // A session that stops elsewhere (written by `edit`, or before the settle test): its stage
    // is refined as it says, by a deformer set up for that.
    refine_settle_ = stage.refine_settle;
    stop_pipeline();
    deformer_.reset();
    deformer_constraints_ = {};
  }
  active_handle_ = std::min(active_handle_, std::max(0, static_cast<int>(handles_.size()) - 1));
}

void Document::relabel(int vertex, int label) {
  int& current = labels_[static_cast<std::size_t>(vertex)];
  if (current == label) return;
  ++painted_version_;
  if (current >= 0) --handle_sizes_[static_cast<std::size_t>(current)];
  if (label >= 0) ++handle_sizes_[static_cast<std::size_t>(label)];
  current = label;
}

void Document::refresh_pivot(int handle) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::size_t count = 0;
  for (std::size_t v = 0; v < labels_.size(); ++v) {
    if (labels_[v] != handle) continue;
    centroid += rest_->positions.row(static_cast<Eigen::Index>(v)).transpose();
    ++count;
  }
  if (count == 0) return;
  auto& transform = handles_[static_cast<std::size_t>(handle)].transform;
  transform = HandleTransform::about_pivot(transform.axis, centroid / static_cast<double>(count), transform.angle, transform.scale, transform.shift);
}

void Document::paint(std::span<const int> vertices, Layer layer, bool erase) {
  if (layer == Layer::RegionOfInterest) {
    for (const int v : vertices) {
      const auto vertex = static_cast<std::size_t>(v);
      if (roi_[vertex] == !erase) continue;
      roi_[vertex] = !erase;
      ++painted_version_;
      if (erase) --roi_count_;
      else ++roi_count_;
    }
    return;
  }
  if (layer == Layer::Handle && handles_.empty()) add_handle();
  const int label = layer == Layer::Fixed ? kFixed : active_handle_;
  std::vector<bool> touched(handles_.size(), false);
  for (const int v : vertices) {
    const int current = labels_[static_cast<std::size_t>(v)];
    if (erase) {
      if (current != label) continue;
      relabel(v, kFree);
    } else {
      relabel(v, label);
    }
    if (current >= 0) touched[static_cast<std::size_t>(current)] = true;
  }
  if (label >= 0) touched[static_cast<std::size_t>(label)] = true;
  for (std::size_t h = 0; h < handles_.size(); ++h) {
    if (touched[h]) refresh_pivot(static_cast<int>(h));
  }
}

std::vector<bool> Document::members(Layer layer) const {
  std::vector<bool> result(labels_.size());
  for (std::size_t v = 0; v < labels_.size(); ++v) {
    switch (layer) {
      case Layer::RegionOfInterest: result[v] = roi_[v]; break;
      case Layer::Fixed: result[v] = labels_[v] == kFixed; break;
      case Layer::Handle: result[v] = labels_[v] == active_handle_; break;
    }
  }
  return result;
}

void Document::set_members(Layer layer, const std::vector<bool>& wanted) {
  std::vector<int> added, removed;
  const auto now = members(layer);
  for (std::size_t v = 0; v < wanted.size(); ++v) {
    if (wanted[v] && !now[v]) added.push_back(static_cast<int>(v));
    if (!wanted[v] && now[v]) removed.push_back(static_cast<int>(v));
  }
  paint(removed, layer, true);
  paint(added, layer, false);
}

void Document::invert(Layer layer) {
  auto wanted = members(layer);
  for (std::size_t v = 0; v < wanted.size(); ++v) {
    // Fixed and handle take only vertices that no other class holds.
    const bool free_for_layer = layer == Layer::RegionOfInterest || labels_[v] == kFree || wanted[v];
    wanted[v] = !wanted[v] && free_for_layer;
  }
  set_members(layer, wanted);
}

void Document::grow(Layer layer) {
  auto wanted = grown(members(layer), adjacency());
  if (layer != Layer::RegionOfInterest) {
    const auto now = members(layer);
    for (std::size_t v = 0; v < wanted.size(); ++v) wanted[v] = wanted[v] && (now[v] || labels_[v] == kFree);
  }
  set_members(layer, wanted);
}

void Document::shrink(Layer layer) { set_members(layer, shrunk(members(layer), adjacency())); }

void Document::clear(Layer layer) { set_members(layer, std::vector<bool>(labels_.size(), false)); }

void Document::set_active_handle(int handle) {
  if (handle >= 0 && handle < static_cast<int>(handles_.size())) active_handle_ = handle;
}

int Document::add_handle() {
  ++painted_version_;
  handles_.push_back({HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero(), 0.0)});
  handle_sizes_.push_back(0);
  active_handle_ = static_cast<int>(handles_.size()) - 1;
  return active_handle_;
}

void Document::remove_handle(int handle) {
  if (handle < 0 || handle >= static_cast<int>(handles_.size())) return;
  ++painted_version_;
  for (auto& label : labels_) {
    if (label == handle) label = kFree;
    else if (label > handle) --label;
  }
  handles_.erase(handles_.begin() + handle);
  handle_sizes_.erase(handle_sizes_.begin() + handle);
  active_handle_ = std::min(active_handle_, std::max(0, static_cast<int>(handles_.size()) - 1));
}

std::size_t Document::fixed_count() const { return painted().fixed.size(); }

std::size_t Document::handle_size(int handle) const { return handle_sizes_[static_cast<std::size_t>(handle)]; }

void Document::set_pose(int handle, const Eigen::Vector3d& axis, double angle, double scale, const Eigen::Vector3d& shift) {
  auto& transform = handles_[static_cast<std::size_t>(handle)].transform;
  transform = HandleTransform::about_pivot(axis, transform.pivot, angle, scale, shift);
}

void Document::reset_poses() {
  for (auto& handle : handles_) {
    handle.transform = HandleTransform::about_pivot(handle.transform.axis, handle.transform.pivot, 0.0, 1.0, Eigen::Vector3d::Zero());
  }
}

void Document::apply() {
  const EditStage stage = current_stage();
  if (stage.handles.empty()) return;
  auto rest = std::make_shared<Mesh>(*rest_);
  rest->positions = result();
  applied_.push_back(stage);
  rest_ = std::move(rest);
  reset_poses();
  for (std::size_t h = 0; h < handles_.size(); ++h) refresh_pivot(static_cast<int>(h));
}

void Document::commit(std::string what) {
  Snapshot snapshot{session(), rest_, std::move(what)};
  const Snapshot& last = history_[history_index_];
  if (snapshot.session == last.session && snapshot.rest == last.rest) return;
  history_.resize(history_index_ + 1);
  history_.push_back(std::move(snapshot));
  if (history_.size() > kHistoryLimit) {
    history_.erase(history_.begin());
    saved_index_ = saved_index_ == 0 ? history_.size() : saved_index_ - 1;
  }
  history_index_ = history_.size() - 1;
}

void Document::restore(const Snapshot& snapshot) {
  applied_ = snapshot.session.applied;
  rest_ = snapshot.rest;
  active_handle_ = snapshot.session.active_handle;
  options_.resolution = snapshot.session.resolution;
  options_.base_vertices = snapshot.session.base_vertices;
  options_.precision = snapshot.session.precision.value_or(FactorPrecision::Double);
  load_stage(snapshot.session.current);
}

// A change not yet committed (a value still being typed, a field dragged) is what the user
// sees: undo first records it, so that it can be redone, and so that it goes back to the step
// before it rather than to an older one.
bool Document::undo() {
  commit();
  if (!can_undo()) return false;
  last_history_step_ = history_[history_index_].what;
  const Snapshot& snapshot = history_[--history_index_];
  restore(snapshot);
  return true;
}

// After an uncommitted change the redo branch is gone (commit() truncates it): redo never
// replaces what the user sees with an older state.
bool Document::redo() {
  commit();
  if (!can_redo()) return false;
  const Snapshot& snapshot = history_[++history_index_];
  last_history_step_ = snapshot.what;
  restore(snapshot);
  return true;
}

bool Document::modified() const { return history_index_ != saved_index_; }
void Document::mark_saved() { saved_index_ = history_index_; }
void Document::mark_saved(const Session& written) {
  if (session() == written) mark_saved();
}
void Document::mark_unsaved() { saved_index_ = std::numeric_limits<std::size_t>::max(); }

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
      same_constraints(build->constraints, current_stage().constraints()) && build->rest == rest_ && build->choice == solve_choice();
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
  return same_constraints(constraints, deformer_constraints_) && deformer_rest_ == rest_.get() && deformer_choice_ == solve_choice();
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
  if (!same_constraints(deformer_constraints_, stage.constraints()) && !previous_selection_answers(stage)) return 0;
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

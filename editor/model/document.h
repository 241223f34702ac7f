#pragma once
// The editor's model, free of any window or GPU code: a session (mesh, applied stages, the
// current stage) and what derives from it — the rest shape, the deformer for the current
// constraints (rebuilt on a worker thread whenever they change, so painting never blocks), and
// the update pipeline that turns handle poses into positions off the UI thread. Every finished
// action is an undoable step.
#include <Eigen/Core>
#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "hdeform/deformer.h"
#include "hdeform/update_pipeline.h"
#include "selection.h"
#include "session.h"

namespace hdeform::cli {

enum class Layer { RegionOfInterest, Fixed, Handle };

class Document {
 public:
  // What a publication holds: the paper's update of every vertex; of the partial vertices only
  // (request_update(true): the others hold an earlier answer); a refinement iteration with more to
  // come (a settling shape, replaced within moments unless a new request replaces it first); or the
  // refinement's last (converged, or at its cap).
  enum class Answer { Whole, Partial, Settling, Refined };
  // Called on a worker thread with each finished update's positions, the number that
  // request_update() returned for it, and what they are.
  using Publish = std::function<void(const Eigen::MatrixXd& positions, std::uint64_t request, Answer answer)>;

  static constexpr int kFree = -1;
  static constexpr int kFixed = -2;

  // Replays the session's applied stages (slow for a large mesh: call from a worker). Throws
  // InputError for indices that do not fit the mesh.
  Document(Session session, Mesh base, DeformerOptions options, Publish publish);
  ~Document();
  Document(const Document&) = delete;
  Document& operator=(const Document&) = delete;

  // Sets where results go; only before the first poll() (no pipeline yet).
  void set_publish(Publish publish) { publish_ = std::move(publish); }
  // Called on the pipeline's thread after each publication's state is recorded (settled(),
  // refinement()), and again once a finished refinement's digest is: the window wakes to show
  // the shape whole or announce it. Only before the first poll().
  void set_wake(std::function<void()> wake) { wake_ = std::move(wake); }

  // The state as a session (lists rebuilt from the per-vertex labels).
  Session session() const;
  const Mesh& rest() const { return *rest_; }
  // The same, for work that may outlive the document's next rest shape (or the document).
  std::shared_ptr<const Mesh> shared_rest() const { return rest_; }
  Eigen::Index vertex_count() const { return rest_->vertex_count(); }
  // Built on the first call, or taken from prepare_adjacency()'s build (main thread only).
  const VertexAdjacency& adjacency() const;
  // Builds the adjacency on a thread of its own, unless it is built or being built: the editor
  // asks once the cores are free, so that neither opening a scan nor the first Grow waits for it
  // (0.43 s at 3.3 million triangles).
  void prepare_adjacency();

  // Per-vertex classes: kFree, kFixed or a handle index; and the region of interest (when empty,
  // the whole mesh).
  int label(int vertex) const { return labels_[static_cast<std::size_t>(vertex)]; }
  bool has_region_of_interest() const { return roi_count_ > 0; }
  std::size_t region_of_interest_size() const { return roi_count_; }
  std::size_t fixed_count() const;
  bool in_region_of_interest(int vertex) const { return roi_[static_cast<std::size_t>(vertex)]; }

  // Painting (one history step per call to commit()). Fixed and handle are exclusive: painting
  // one takes the vertex from the other. `erase` removes the layer from the vertices.
  void paint(std::span<const int> vertices, Layer layer, bool erase);
  void invert(Layer layer);
  void grow(Layer layer);
  void shrink(Layer layer);
  void clear(Layer layer);

  std::size_t handle_count() const { return handles_.size(); }
  int active_handle() const { return active_handle_; }
  void set_active_handle(int handle);
  int add_handle();  // becomes active
  void remove_handle(int handle);
  std::size_t handle_size(int handle) const;

  // The active handle's pose: about its pivot (the centroid of its rest vertices).
  const HandleTransform& pose(int handle) const { return handles_[static_cast<std::size_t>(handle)].transform; }
  void set_pose(int handle, const Eigen::Vector3d& axis, double angle, double scale, const Eigen::Vector3d& shift);
  void reset_poses();
  // Makes the current result the rest shape (the stage is kept, its poses reset).
  void apply();

  // Records the current state as one undo step if it differs from the last one; `what` names
  // the step for the status line ("paint fixed", "move handle 1").
  void commit(std::string what = "edit");
  bool can_undo() const { return history_index_ > 0; }
  bool can_redo() const { return history_index_ + 1 < history_.size(); }
  // Both first commit a pending change (so it is never lost: undo goes to the step before it,
  // and redo finds no branch to replace it with).
  bool undo();
  bool redo();
  // The name of the step the last undo() took back or redo() brought again.
  const std::string& last_history_step() const { return last_history_step_; }
  // Whether the state differs from the one last marked saved.
  bool modified() const;
  // Until the next save, modified() whatever undo does (a state restored after a crash).
  void mark_unsaved();
  void mark_saved();
  // After a save of `written` finished: saved, if that is still the state (a key pressed in the
  // frame of Ctrl+S may have changed it while the files were written).
  void mark_saved(const Session& written);

  // Solver state, for the UI.
  enum class SolverState { NoHandle, Building, Ready, Failed };
  SolverState solver_state() const;
  std::string solver_message() const;  // the build's current stage, or the failure
  // Call each frame on the UI thread: installs a finished rebuild, starts one when needed.
  void poll();
  // While a stroke is being painted its selection is not final: poll() then starts no set-up
  // (it still installs one that finished). At 13M triangles a set-up takes 25 s and cannot be
  // stopped, so one started at a stroke's first frame held up the stroke's own by as long.
  void hold_set_up(bool hold) { hold_set_up_ = hold; }
  // The set-up in progress takes the rest shape's operators (weights, Laplacian and order, the
  // base mesh) from an earlier one instead of computing them.
  bool set_up_reuses_operators() const;
  // How many set-ups stopped early because the rest shape or the solve choice changed under them.
  std::size_t set_ups_stopped() const { return set_ups_stopped_; }
  // The harmonic field of the ready deformer, or nullptr.
  const Eigen::VectorXd* field() const;
  const DeformerTimings* setup_timings() const;
  // The vertices the solves run on (the base's with multiresolution); 0 before a set-up.
  Eigen::Index solved_vertex_count() const;
  // How the ready deformer's factor is stored (the session's choice until one is ready), and what
  // refining its single-precision solves has taken.
  FactorPrecision factor_precision() const;
  SparseCholesky::Refinement factor_refinement() const;
  // What the ready deformer found about the mesh and the selection (Deformer::warnings).
  std::vector<std::string> warnings() const;
  double last_update_ms() const { return last_update_ms_.load(); }
  const DeformerOptions& options() const { return options_; }
  // The solver's other options (its backend); where the session solves stays as it is.
  void set_options(const DeformerOptions& options);

  // Where the session solves: on every vertex or on a base of `base_vertices` (read for Exact
  // too: the base a switch back to Multiresolution asks for), and how its factors are stored.
  // Part of the state, so undoable and in the session; a change sets the solver up again, and
  // until then the drag goes on with the set-up in place.
  struct SolveChoice {
    Resolution resolution = Resolution::Exact;
    Eigen::Index base_vertices = kDefaultBaseVertices;
    FactorPrecision precision = FactorPrecision::Double;
    bool operator==(const SolveChoice&) const = default;
  };
  SolveChoice solve_choice() const { return {options_.resolution, options_.base_vertices, options_.precision}; }
  // Only while no stage is applied: the applied stages were solved where the session says, and
  // their replay elsewhere would give another rest shape.
  bool can_change_solve_choice() const { return applied_.empty(); }
  // Throws std::logic_error when !can_change_solve_choice(), std::invalid_argument for Automatic
  // or a base of fewer than 4 vertices. Not committed (commit() names the step).
  void set_solve_choice(const SolveChoice& choice);

  // As-rigid-as-possible refinement of the current stage (on for new sessions in the editor):
  // part of the state, so undoable and in the session. The pipeline refines after each update.
  bool refine() const { return refine_; }
  void set_refine(bool on);
  // How long the input must rest before refinement runs (UpdatePipeline::set_refinement_delay).
  void set_refinement_delay(std::chrono::milliseconds delay);
  // ... and how often its iterations are shown (UpdatePipeline::set_refinement_publication_interval).
  void set_refinement_publication_interval(std::chrono::milliseconds interval);
  // Where its refinement stops (EditStage::refine_settle): the editor's kEditorSettle for a new
  // session, the session's own value for one opened.
  double refine_settle() const { return refine_settle_; }
  // The refinement of the latest publication: its iterations (0: the paper's update alone),
  // energies and whether it converged, the last iteration's time, and which request it answers.
  struct RefinementView {
    RefinementStatus status;
    double iteration_ms = 0.0;
    std::uint64_t request = 0;
    std::string digest;  // positions_digest of the positions: once finished, a moment after (empty until then)
    bool finished = false;  // converged, or stopped at the cap of iterations: nothing more comes
  };
  RefinementView refinement() const;
  // Whether the newest poses have their final shape on screen: solved and, with refinement on,
  // refined until its stop; or their answer failed (answer_failure()), and nothing more comes.
  // Then result() returns (or throws) at once.
  bool settled() const;
  // Why the newest poses' answer failed (their update, or its refinement, threw: out of memory,
  // say), and the request it answered; an empty `why` when it did not. The screen keeps the last
  // shape published; result() throws `why`. New poses, or refinement turned off, are solved again.
  // Any thread (a wake may ask).
  struct AnswerFailure {
    std::uint64_t request = 0;
    std::string why;
  };
  AnswerFailure answer_failure() const;
  // The stage timings of the updates and refinement iterations published since the last call
  // (for the profiler panel; at most the last few hundred are kept).
  std::vector<UpdateTimings> take_update_timings();
  std::vector<RefinementTimings> take_refinement_timings();

  // Posts the current poses to the pipeline (newest wins); returns the request number (0 when
  // nothing can be solved yet). While a new selection is set up, the poses are solved with the
  // previous one (drags_previous_selection()).
  std::uint64_t request_update(bool partial = false);
  // The vertices a partial request needs (the proxy's, ascending); null: none, every request whole.
  void set_partial_vertices(std::shared_ptr<const std::vector<int>> vertices) { partial_vertices_ = std::move(vertices); }
  // Whether a set-up for a changed selection (or solve choice) is running while the previous
  // selection's solver (same rest shape and number of handles) still answers the drag.
  bool drags_previous_selection() const;
  std::uint64_t last_published_request() const { return last_published_.load(); }
  // The positions for the current poses: the pipeline's final answer to them, the shape the
  // screen shows once settled, which is exactly what `hdeform edit --session` computes (waits for
  // a pending rebuild, the update in flight and the refinement until its stop). Throws SolveError
  // when the set-up or the answer failed (answer_failure()).
  Eigen::MatrixXd result();
  // Blocks until no rebuild is running (for tests and saving).
  void wait_until_ready();
  // Stops the update pipeline (nothing is published once this returns) and asks a set-up in
  // progress to stop at its next stage, so that the rest of the document can be let go of on
  // another thread while the next one opens.
  void close();

 private:
  struct Handle {
    HandleTransform transform;
  };
  struct Snapshot {
    Session session;
    std::shared_ptr<const Mesh> rest;
    std::string what;  // the step that led to this state
  };
  struct Build;
  struct AdjacencyBuild;

  EditStage current_stage() const;
  void load_stage(const EditStage& stage);
  void restore(const Snapshot& snapshot);
  void relabel(int vertex, int label);
  void refresh_pivot(int handle);
  std::vector<bool> members(Layer layer) const;
  void set_members(Layer layer, const std::vector<bool>& members);
  void start_build();
  void install_build();
  // The deformer in place (or its failure) is for the current constraints, rest and solve choice.
  bool deformer_is_current(const EditConstraints& constraints) const;
  // A set-up is running and the deformer in place can take `stage`'s poses (same rest shape, as
  // many non-empty handles).
  bool previous_selection_answers(const EditStage& stage) const;
  void stop_pipeline();

  std::string mesh_name_;
  std::vector<EditStage> applied_;
  std::shared_ptr<const Mesh> rest_;
  mutable std::optional<VertexAdjacency> adjacency_;  // see adjacency()
  mutable std::unique_ptr<AdjacencyBuild> adjacency_build_;
  std::vector<int> labels_;
  std::vector<bool> roi_;
  std::size_t roi_count_ = 0;
  std::vector<Handle> handles_;
  std::vector<std::size_t> handle_sizes_;
  // The vertex lists of the painted sets, built again only after a change (current_stage() runs
  // every frame and for every request: at 1.6 million vertices a build took 5 ms).
  struct PaintedLists {
    std::uint64_t version = ~std::uint64_t{0};
    std::vector<int> region_of_interest, fixed;
    std::vector<std::vector<int>> handles;  // by handle, empty ones too
  };
  std::uint64_t painted_version_ = 0;  // bumped by every change of labels_, roi_ or the handles
  mutable PaintedLists painted_;
  const PaintedLists& painted() const;
  int active_handle_ = 0;

  DeformerOptions options_;
  Publish publish_;
  std::function<void()> wake_;
  std::unique_ptr<Deformer> deformer_;
  EditConstraints deformer_constraints_;
  const Mesh* deformer_rest_ = nullptr;
  SolveChoice deformer_choice_;
  // The rest shape's weights and Laplacian, kept across selections (a stroke re-factors only).
  std::shared_ptr<const MeshOperators> operators_;
  std::shared_ptr<const Mesh> operators_rest_;
  std::unique_ptr<UpdatePipeline> pipeline_;
  std::unique_ptr<Build> build_;
  std::string failure_;
  std::atomic<double> last_update_ms_{0.0};
  bool refine_ = false;
  double refine_settle_ = 0.0;
  std::optional<EditStage> submitted_;  // the stage whose poses the pipeline was last asked for
  std::chrono::milliseconds refinement_delay_{0};
  std::chrono::milliseconds publication_interval_{0};
  mutable std::mutex refinement_mutex_;
  RefinementStatus refinement_;
  double refinement_ms_ = 0.0;
  std::uint64_t refinement_request_ = 0;  // the request the refinement view answers
  std::string refinement_digest_;
  bool refinement_finished_ = false;
  std::uint64_t failed_request_ = 0;  // with refinement_mutex_: the last request whose answer failed
  std::string answer_failure_;        // ... and why
  std::vector<UpdateTimings> update_timings_;          // with refinement_mutex_
  std::vector<RefinementTimings> refinement_timings_;  // with refinement_mutex_
  std::atomic<std::uint64_t> last_published_{0};
  std::uint64_t request_base_ = 0;  // requests of earlier pipelines, so that numbers keep growing
  std::atomic<std::uint64_t> last_request_{0};  // written by the window's thread; answer_failure() reads it from any
  std::shared_ptr<const std::vector<int>> partial_vertices_;

  std::vector<Snapshot> history_;
  std::size_t history_index_ = 0;
  std::size_t saved_index_ = 0;
  bool hold_set_up_ = false;
  std::size_t set_ups_stopped_ = 0;
  std::string last_history_step_;
};

}  // namespace hdeform::cli

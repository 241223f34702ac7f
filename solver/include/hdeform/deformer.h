#pragma once
/// @file
/// The editing engine (paper §5, §7): everything that depends only on the mesh and the vertex
/// classes is computed once — Laplacian, factorization of L_ff, harmonic field, rest gradients —
/// and each handle transform after that costs a deformation field, a right-hand side and
/// back-substitution. This is the object the editor and the batch commands drive.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/handle_transform.h"
#include "hdeform/mesh.h"
#include "hdeform/mesh_check.h"
#include "hdeform/multiresolution.h"
#include "hdeform/refinement.h"
#include "hdeform/sparse_cholesky.h"

namespace hdeform {
namespace detail {
class ArapRefinement;
}

/// Where the solves run: on the mesh itself, or on a base mesh that carries the fine mesh's detail
/// (multiresolution.h).
enum class Resolution {
  Automatic,        ///< Multiresolution from kMultiresolutionFrom vertices on, Exact below
  Exact,            ///< every vertex an unknown of the solves
  Multiresolution,  ///< the solves on a base of base_vertices, the detail carried
};
/// The resolution's name: "automatic", "exact", "multiresolution".
std::string_view to_string(Resolution resolution);
/// The resolution named by `name` (as to_string spells it), or nullopt.
std::optional<Resolution> parse_resolution(std::string_view name);
/// What Automatic means for a mesh of `vertices` vertices (Exact or Multiresolution).
Resolution resolution_for(Eigen::Index vertices, Resolution asked = Resolution::Automatic);

/// Called from the constructing thread before each set-up stage, with a line for the user.
using ProgressCallback = std::function<void(std::string_view stage)>;

/// How a Deformer factors, solves and refines; the defaults are what the editor and the commands use.
struct DeformerOptions {
  SolverBackend backend = default_backend();
  SolveSchedule schedule = default_schedule();
  /// How the factor is stored: Single halves its values' memory, and each solve then takes one or
  /// two correction steps more (README, Performance).
  FactorPrecision precision = FactorPrecision::Double;
  Resolution resolution = Resolution::Automatic;
  Eigen::Index base_vertices = kDefaultBaseVertices;  ///< the base's size, with multiresolution
  RefinementOptions refinement;
  /// Set up the as-rigid-as-possible refinement with the rest (else at the first refine()).
  bool prepare_refinement = false;

  /// The defaults with this backend and schedule.
  static DeformerOptions solver(SolverBackend backend, SolveSchedule schedule = default_schedule()) {
    DeformerOptions options;
    options.backend = backend;
    options.schedule = schedule;
    return options;
  }
};

/// Where the last update's time went, milliseconds per stage (stages of one update may overlap:
/// the constrained targets are computed while the maps are).
struct UpdateTimings {
  double field_ms = 0.0;    ///< several handles: the five interpolated fields
  double detail_ms = 0.0;   ///< multiresolution: the fine mesh rebuilt from the base
  double maps_ms = 0.0;     ///< per-triangle maps
  double targets_ms = 0.0;  ///< fixed and handle positions
  double rhs_ms = 0.0;      ///< Poisson right-hand side
  double solve_ms = 0.0;    ///< x, y, z back-substitution
  double write_ms = 0.0;    ///< free positions out
  double total_ms = 0.0;    ///< the whole update, as the caller waits for it
};

/// Where a Deformer's set-up time went, milliseconds per stage.
struct DeformerTimings {
  double laplacian_ms = 0.0;  ///< weights, inspection, partition and Laplacian (the partition alone when reused)
  double factor_ms = 0.0;  ///< analyse + numeric factorization of L_ff
  double field_ms = 0.0;   ///< harmonic field solve
  double base_ms = 0.0;    ///< multiresolution: the base mesh, the detail encoding, and the operators of both meshes
};

/// What depends on the rest mesh alone: cotangent weights, the inspection, the Laplacian and a
/// fill-reducing elimination order of its pattern (about half of a set-up). A Deformer for a new
/// selection on the same mesh takes them from the last one (Deformer::operators()) instead of
/// computing them again.
struct MeshOperators {
  CotangentWeights weights;
  MeshInspection inspection;
  Eigen::SparseMatrix<double> laplacian;
  /// elimination_rank[v]: vertex v's place in an elimination order of the whole Laplacian
  /// (elimination_ranks: AMD, or nested dissection on a large mesh). Eliminating the
  /// free vertices in the order it induces fills in no more than that order fills the whole
  /// matrix (a fill path among free vertices is one in the whole mesh), so every selection's
  /// L_ff is factored without an ordering of its own.
  std::vector<int> elimination_rank;
  double ms = 0.0;  ///< what computing them took

  /// With multiresolution, the mesh's own Laplacian and order are left empty (only the weights and
  /// the inspection are the fine mesh's): the solves run on the base, with its own operators.
  struct Multiresolution {
    BaseMesh base;
    DetailEncoding encoding;
    std::shared_ptr<const MeshOperators> base_operators;
    Eigen::Index requested_vertices = 0;  ///< the base's size asked for (the base may keep more)
    double ms = 0.0;                      ///< simplification and encoding
  };
  std::shared_ptr<const Multiresolution> multiresolution;
  /// Why Automatic stayed exact on a mesh of multiresolution's size (the base lost the topology).
  std::string exact_because;

  /// Exact, or Multiresolution when the solves run on a base mesh.
  Resolution resolution() const { return multiresolution ? Resolution::Multiresolution : Resolution::Exact; }

  /// Runs validate_mesh. `resolution` as in DeformerOptions (Automatic: by the mesh's size).
  /// Throws SolveError when Multiresolution was asked for and no base keeps the mesh's topology.
  static std::shared_ptr<const MeshOperators> of(const Mesh& mesh, Resolution resolution = Resolution::Automatic,
                                                 Eigen::Index base_vertices = kDefaultBaseVertices, const ProgressCallback& progress = {});

  /// The analysis of the last L_ff factored with these operators, for the next set-up whose free
  /// vertices are the same (thread-safe).
  std::shared_ptr<const SparseCholesky::Analysis> last_analysis() const;
  /// Records `analysis` as the last one (thread-safe); see last_analysis().
  void keep_analysis(std::shared_ptr<const SparseCholesky::Analysis> analysis) const;

 private:
  mutable std::mutex analysis_mutex_;
  mutable std::shared_ptr<const SparseCholesky::Analysis> last_analysis_;
};

/// The paper's editing engine for one mesh and one selection: set up once, then `deform` per drag
/// event (the paper's update) and `refine` after it (as-rigid-as-possible). Not thread-safe: one
/// caller at a time (UpdatePipeline runs it off the caller's thread).
class Deformer {
 public:
  // Throws InputError for invalid constraints (no handle, bad indices) and SolveError when the
  // factorization fails.
  /// Sets everything up: validates the mesh, builds (or takes from `options`) the operators,
  /// factors L_ff and solves the harmonic field; `progress` is called before each stage. Throws
  /// InputError for bad constraints (a handle without a sink, indices out of range) and SolveError
  /// when a factorization fails.
  Deformer(Mesh rest, EditConstraints constraints, DeformerOptions options = {}, const ProgressCallback& progress = {});
  /// The same, with the operators of this very mesh computed before (MeshOperators::of(rest), or
  /// another Deformer's operators() on it): a re-selection. Throws std::invalid_argument when their
  /// sizes do not fit the mesh. Operators of the other resolution than options.resolution asks
  /// for (Automatic takes either) are computed again.
  Deformer(Mesh rest, EditConstraints constraints, std::shared_ptr<const MeshOperators> operators, DeformerOptions options = {},
           const ProgressCallback& progress = {});
  /// The same, sharing the rest mesh instead of holding a copy (at 3.3 million triangles a copy
  /// is 79 MB). Throws std::invalid_argument when `rest` is null.
  Deformer(std::shared_ptr<const Mesh> rest, EditConstraints constraints, std::shared_ptr<const MeshOperators> operators,
           DeformerOptions options = {}, const ProgressCallback& progress = {});
  ~Deformer();
  Deformer(const Deformer&) = delete;
  Deformer& operator=(const Deformer&) = delete;

  /// The rest mesh, as given.
  const Mesh& rest() const { return rest_; }
  /// The vertex classes, as given.
  const EditConstraints& constraints() const { return constraints_; }
  /// Each vertex's role and handle, with stray components fixed.
  const VertexPartition& partition() const { return partition_; }
  /// The legal but troublesome geometry found in the mesh (for warnings).
  const MeshInspection& inspection() const { return operators_->inspection; }
  /// The operators of the rest mesh, to share with the next Deformer on the same mesh.
  const std::shared_ptr<const MeshOperators>& operators() const { return operators_; }
  /// Multiresolution or Exact: what this deformer solves on.
  Resolution resolution() const { return operators_->resolution(); }
  /// The mesh the solves run on: the base with multiresolution, else rest().
  const Mesh& solved_mesh() const { return base_ ? base_->rest() : rest_; }
  /// The system of the mesh the solves run on (the base's with multiresolution).
  const DirichletSystem& system() const { return base_ ? base_->system() : *system_; }
  /// The options it was made with.
  const DeformerOptions& options() const { return options_; }
  /// Where the set-up's time went.
  const DeformerTimings& timings() const { return timings_; }
  /// The harmonic field h: 1 at every handle vertex, 0 at fixed vertices.
  const Eigen::VectorXd& field() const { return field_; }
  /// The number of handles; deform() takes one transform each.
  std::size_t handle_count() const { return constraints_.handles.size(); }
  /// Mesh, partition and handle-shape findings the user should see.
  std::vector<std::string> warnings() const;

  /// Where the last update's time went.
  const UpdateTimings& last_update() const { return last_update_; }

  /// Deformed positions (n×3, resized if needed) for one transform per handle: one handle blends
  /// its rotation and scale along h (§5), several interpolate q0..q3 and s harmonically (§7).
  /// Not reentrant. Allocation-free once `positions` has the right size. Begins a new edit for
  /// refine(), whose iterations start where `start` says (refinement.h): by default from the
  /// paper's result, so that the refined shape of a pose is the same bits whatever came before.
  void deform(std::span<const HandleTransform> transforms, Eigen::MatrixXd& positions,
              RefinementStart start = RefinementStart::FromPapersResult);
  /// deform() where only `vertices` are needed now (the editor's drag, drawing a proxy over them):
  /// solved on a base (multiresolution), only they are rebuilt from it, each with the bits deform()
  /// gives it, and the constrained vertices are placed; the other rows of `positions` (which must
  /// have the mesh's size) keep what they held until complete(). Returns whether every row was
  /// written (an exact solve writes them all).
  bool deform_vertices(std::span<const HandleTransform> transforms, Eigen::MatrixXd& positions, std::span<const int> vertices,
                       RefinementStart start = RefinementStart::FromPapersResult);
  /// Rebuilds every row of the last update from its base: after deform_vertices(), `positions`
  /// is then what deform() would have written. Nothing to do for an exact solve.
  void complete(Eigen::MatrixXd& positions);

  /// As-rigid-as-possible refinement (refinement.h) of the last deform(): runs up to
  /// `max_iterations` local/global iterations, fewer once they have converged (RefinementOptions),
  /// then writes the free rows of `positions` (the buffer deform() filled). Successive calls
  /// continue the same edit. Returns the iterations run. Allocation-free after the first call.
  int refine(Eigen::MatrixXd& positions, int max_iterations);
  /// refine() that leaves `positions` as they are, for a caller that shows only some of the
  /// iterations: write_refined() writes the shape they reached. On a base the write is the fine
  /// mesh's rebuild, as long as the base's iteration at scan resolution.
  int refine_unwritten(const Eigen::MatrixXd& positions, int max_iterations);
  /// Writes what refine() would have written after the iterations run since the last deform()
  /// (nothing if none ran).
  void write_refined(Eigen::MatrixXd& positions);
  /// ... one iteration at a time, for a caller that shows each (false once converged).
  bool refine_once(Eigen::MatrixXd& positions) { return refine(positions, 1) == 1 && !refinement_status().converged; }
  /// Where the last refine() stands: iterations, energies, converged or settled.
  const RefinementStatus& refinement_status() const;
  /// Where the last refinement iteration's time went.
  const RefinementTimings& refinement_timings() const;
  /// Changes the refinement's tolerance, settle test, acceleration and cap for the next refine().
  void set_refinement_options(const RefinementOptions& options);
  /// The refinement options now in force.
  const RefinementOptions& refinement_options() const { return options_.refinement; }

 private:
  void set_up_on_base(const ProgressCallback& progress);
  /// Fixed vertices at rest, handle vertices moved by their handle's transform.
  void write_constrained(std::span<const HandleTransform> transforms, Eigen::MatrixXd& positions) const;
  /// Multiresolution: the whole fine mesh from base_positions_, its constrained vertices where
  /// the last transforms put them (`positions` has the fine size).
  void rebuild_from_base(Eigen::MatrixXd& positions) const;
  // deform(), and deform_vertices() with `only_vertices`: on a base, only those rows are rebuilt.
  void update(std::span<const HandleTransform> transforms, Eigen::MatrixXd& positions, RefinementStart start,
              const std::span<const int>* only_vertices);
  struct UpdateArena;
  struct UpdateGraph;
  void prepare_update_triangles();
  void prepare_refinement();
  void begin_refinement(const Eigen::MatrixXd& positions);
  // Throws std::invalid_argument, naming `caller`, unless `positions` has the mesh's n×3 shape.
  void expect_result_rows(const Eigen::MatrixXd& positions, const char* caller) const;

  std::shared_ptr<const Mesh> shared_rest_;
  const Mesh& rest_;  // *shared_rest_
  EditConstraints constraints_;
  DeformerOptions options_;
  DeformerTimings timings_;
  UpdateTimings last_update_;
  std::shared_ptr<const MeshOperators> operators_;
  std::vector<std::string> handle_warnings_;
  std::vector<std::string> base_warnings_;  // what the base mesh cannot hold of the sets
  VertexPartition partition_;
  std::unique_ptr<DirichletSystem> system_;
  std::unique_ptr<class PoissonAssembler> assembler_;
  Eigen::VectorXd field_;
  std::vector<int> update_triangles_;      ///< mesh triangles with a free corner, in assembly order
  Eigen::MatrixXi update_mesh_triangles_;  ///< their corners
  Eigen::VectorXd triangle_field_;         ///< h at their barycenters
  /// The update graph lives in an arena of its own, which whatever thread calls deform() joins as
  /// its master while the TBB workers help. Attached to the constructing thread's arena instead,
  /// the graph could only be driven by delegating to a worker, and on 2 cores that left the
  /// update's parallel stages one thread (8.0 ms instead of 4.8 ms per buddha-206k update).
  std::unique_ptr<UpdateArena> update_arena_;
  std::unique_ptr<UpdateGraph> graph_;
  std::unique_ptr<detail::ArapRefinement> refinement_;
  std::vector<HandleTransform> edited_;  ///< the transforms of the last deform()
  bool refinement_pending_ = false;      ///< deform() ran since the refinement last began an edit
  RefinementStart refinement_start_ = RefinementStart::FromPapersResult;  ///< of the last deform()
  std::optional<HandleTransform> field_of_;  ///< one handle: the transform the refinement's field rotations are of
  /// Multiresolution: the deformer of the base, and its last positions.
  std::unique_ptr<Deformer> base_;
  Eigen::MatrixXd base_positions_;
  /// The foot triangles all of whose fine vertices are constrained: write_constrained places
  /// them, so the rebuild skips them.
  std::vector<char> rebuild_skip_;
};

}  // namespace hdeform

#pragma once
// The state and the stages of the as-rigid-as-possible refinement (refinement.h) for one Deformer:
// set up once per mesh and partition, then per edit begin() and one iteration after another, each
// iteration the stages assemble → solve → mix → fit (the local step, in arap_local_step.cpp),
// which the Deformer runs as nodes of its update graph. Every stage is parallel over rows or
// vertices with sums in a fixed order, so the result is the same bits for any number of threads;
// nothing allocates after construction.
//
// Both steps are written over pairs (i, v) of a vertex and a neighbour (or itself), with
// coefficients that depend on the rest shape and the per-triangle scales only:
//   local:  A_i = Σ_v p'_v k_ivᵀ,   k_iv = Σ_{t∋i,v} s_t g_{t,v}     (maximise tr(R_iᵀ A_i))
//   global: b_i = Σ_v R_v m_iv,     m_iv = Σ_{t∋i,v} (s_t/3) g_{t,i}  (= Σ_{t∋i} T_t g_{t,i})
// with g_{t,v} = Σ_{b∈t} w^t_vb (p_v − p_b) the Poisson assembly's corner gradients, so an
// iteration reads a few vectors per vertex instead of a matrix per triangle. The energy's
// deformed edges are summed over the same pairs, W_iv ‖p'_v − p'_i‖² (each triangle's edge weighted
// by the triangle's rotation corners, and counted at one of its ends), in the local step's gather.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <span>
#include <vector>

#include "hdeform/dirichlet_system.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh.h"
#include "hdeform/refinement.h"

namespace hdeform {
struct RotationFit;
}

namespace hdeform::detail {

// How far the refinement may turn a vertex about the handle's axis away from the paper's field,
// radians, when the handle turns by more than half a turn. The energy alone cannot hold such a
// twist: free local/global iterations take a bar twisted by two turns back to the rest shape (its
// ends sit where no twist puts them: the belt trick), and one turn into a loop (twist becomes
// writhe, as a real rod buckles). Limited, the rotations keep the paper's turns and settle
// everything else: on the Botsch–Sorkine bar (360° and 720°) and the built-in bar (720°,
// resolutions 16 to 64) every level stays turned further than the one below, the energy falls by
// 8-29% in 17 to 44 iterations, and the corners the paper's twist pulls in towards the axis move
// back out (the smallest radius ratio of the built-in bar 0.17 → 0.24). At 1 radian 720° already
// unwinds on the coarsest bar; at 0.6 the corners come within 5% of the axis.
// A handle that turns less has no limit: a bend is rotation too, and must be free.
inline constexpr double kTurnLimit = 0.2;

class ArapRefinement {
 public:
  // `update_triangles`: the mesh triangles with a free corner, whose maps the Poisson solve reads.
  ArapRefinement(const Mesh& rest, const CotangentWeights& weights, const DirichletSystem& system, std::span<const int> update_triangles,
                 const RefinementOptions& options);

  void set_options(const RefinementOptions& options);
  const RefinementOptions& options() const { return options_; }

  // What the caller fills before begin(): the paper's field rotation at each rotation vertex and
  // its scale at each energy triangle (both in the order of the mesh ids listed here).
  std::span<const int> rotation_vertices() const { return {vertex_.data(), static_cast<std::size_t>(rotation_count_)}; }
  std::span<const int> energy_triangles() const { return triangle_; }
  std::span<Eigen::Quaterniond> field_rotations() { return new_field_; }
  std::span<double> triangle_scales() { return new_scales_; }
  // One handle that turns by more than half a turn: the refined rotations stay within kTurnLimit
  // of the field's about its axis, so the refinement settles the turns the user asked for and
  // never undoes one. None: no limit.
  void set_turn_axis(const std::optional<Eigen::Vector3d>& axis) { turn_axis_ = axis; }

  // A new edit. `positions` holds the paper's result, its constrained rows the targets. The paper's
  // rotations are fitted to it from the field's, whatever came before, so the unrefined energy is
  // the pose's own. From the paper's result, the iterations start there. From the last edit, they
  // start from its refined rotations, turned by the change of the paper's field rotation at each
  // vertex, so that a drag continues from its refined shape while a jump or a twist of several
  // turns still turns as the paper says; if that first iteration ends above the paper's result,
  // the run goes on from the paper's result instead (a step back towards the rest shape, say).
  void begin(const Eigen::MatrixXd& positions, RefinementStart start);
  // An edit that moves nothing (every handle at rest): the paper's result is the rest shape and
  // the energy zero; nothing to iterate. The rotations stay for a later start from the last edit.
  void begin_at_rest();

  // One iteration as four stages, in this order.
  void assemble();  // right-hand side from the current rotations
  void solve();
  void mix();       // Anderson acceleration (or the plain step): the next positions
  void fit();       // rotations fitted to them and the energy (falls back to the plain step if it rose); closes the iteration
  // Writes the free rows of `positions`: once after a run of iterations, since no stage reads them.
  void write(Eigen::MatrixXd& positions) const;

  const RefinementStatus& status() const { return status_; }
  const RefinementTimings& timings() const { return timings_; }
  RefinementTimings& timings() { return timings_; }

 private:
  struct Incidence {  // a triangle around a rotation vertex, and where its corners' pairs are
    int triangle;
    int corner;  // which corner of the triangle the vertex is
    std::array<int, 3> slot;
  };

  void rebuild_coefficients();
  // Holds a fitted rotation within kTurnLimit of the field's about the turn axis; true if it had to.
  bool keep_turns(std::size_t i, const Eigen::Matrix3d& a, const Eigen::Matrix3d& start, RotationFit& fit) const;
  // Fits rotations to the current positions, starting from `start`; returns E.
  double fit_rotations(const std::vector<Eigen::Matrix3d>& start, std::vector<Eigen::Matrix3d>& rotations, int steps);
  // The energy's terms that no iteration changes: the rest edges' (by the scales) and the deformed
  // edges between two vertices without a rotation (both constrained).
  void update_constant_energy();

  const DirichletSystem& system_;
  RefinementOptions options_;

  // Vertices in a compact order: [0, rotation_count_) carry a rotation, the rest are the other
  // corners of the energy's triangles (all constrained).
  // The free vertices come first, compact index = factor row, so the state x is the first rows of
  // positions_.
  std::vector<int> vertex_;
  int rotation_count_ = 0;

  std::vector<int> triangle_;                          // energy triangles (mesh ids)
  std::vector<std::array<int, 3>> triangle_corners_;   // compact vertices
  std::vector<std::array<Eigen::Vector3d, 3>> corner_gradient_;
  std::vector<double> rest_edge_energy_;               // Σ w ‖p_a − p_b‖²
  std::vector<double> corner_multiplicity_;            // corners that carry a rotation
  std::vector<double> scales_, new_scales_;
  struct ConstrainedEdge {  // a deformed edge of the energy between two vertices without a rotation
    int a, b;
    double weight;  // the triangle's rotation corners times w
  };
  std::vector<ConstrainedEdge> constrained_edges_;
  double scaled_rest_energy_ = 0.0;  // Σ_t (rotation corners) s_t² Σ w ‖p_a − p_b‖²
  double constant_energy_ = 0.0;     // that and the constrained edges' deformed energy

  std::vector<std::size_t> local_start_;  // per rotation vertex
  std::vector<int> local_vertex_;
  struct LocalCoefficient {  // of a pair (i, v): k_iv's x, y, z, and W_iv (one load of four lanes)
    alignas(32) std::array<double, 4> values;
  };
  std::vector<LocalCoefficient> local_coefficient_;
  std::vector<std::size_t> incidence_start_;
  std::vector<Incidence> incidence_;

  std::vector<Eigen::Vector3d> global_coefficient_;  // m, for the free vertices' pairs

  std::array<std::vector<Eigen::Matrix3d>, 2> rotation_;
  int current_ = 0;  // rotation_[current_] belongs to the positions in positions_
  std::vector<Eigen::Quaterniond> field_, new_field_;
  // The paper's result of the edit and the rotations fitted to it.
  std::vector<double> paper_;
  std::vector<Eigen::Matrix3d> paper_rotation_;
  std::optional<Eigen::Vector3d> turn_axis_;
  bool has_refined_ = false;  // an edit has begun: its rotations can start the next
  bool consistent_ = false;   // the rotations were fitted to positions_ (not carried over)
  double diagonal_ = 0.0;     // of the rest shape's bounding box (the settle test's unit)

  std::vector<double> positions_;  // compact vertices × 4 (x, y, z, a zero pad)
  std::vector<double> constant_;   // free rows × 4: −Σ L_fc x_c
  std::vector<double> rhs_;        // free rows × 4, becomes the plain step G(x)

  // Anderson acceleration (Walker and Ni's form): differences of G and of the residual F = G − x,
  // free rows × 3 (x, y, z: no solve reads them, so no pad).
  std::array<std::vector<double>, kMaxRefinementHistory> delta_g_, delta_f_;
  std::vector<double> previous_g_, previous_f_;
  Eigen::Matrix<double, kMaxRefinementHistory, kMaxRefinementHistory> gram_;
  int stored_ = 0;  // differences held
  int oldest_ = 0;
  bool has_previous_ = false;
  bool mixed_ = false;  // this iteration's candidate is an accelerated one
  std::vector<double> partial_;  // per-chunk partial sums, a fixed order for any thread count

  double energy_ = 0.0;
  double unlimited_energy_ = 0.0;  // of the last fit, had no turn been held
  double energy_floor_ = 0.0;  // below this the energy counts as zero
  RefinementStatus status_;
  RefinementTimings timings_;
};

}  // namespace hdeform::detail

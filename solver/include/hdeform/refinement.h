#pragma once
/// @file
/// As-rigid-as-possible refinement of an edit (beyond the paper; design.md): local/global
/// iterations of the spokes-and-rims ARAP energy (Chao et al. 2010; CGAL's default and libigl's
/// ARAP_ENERGY_TYPE_SPOKES_AND_RIMS), started from the paper's result and solved against the same
/// factorization:
///
///   E = Σ_i Σ_{t∋i} Σ_{edges ab of t} w^t_ab ‖(p'_a − p'_b) − s_t R_i (p_a − p_b)‖²
///
/// over the vertices i that are a corner of a triangle with a free vertex, w^t_ab = ½ cot of the
/// angle opposite ab, s_t the paper's blended scale at t (so a scale drag still grows the region
/// smoothly). The local step fits R_i (fit_rotation, warm-started); the global step is the Poisson
/// solve with T_t = s_t (R_a + R_b + R_c)/3. Each plain iteration lowers E or leaves it; fixed and
/// handle vertices stay exactly at their targets.
namespace hdeform {

/// Where a run "until converged" stops: at the first iteration that meets either test. The energy
/// test alone is `hdeform edit --refine auto`'s; the editor adds the settle test at
/// kEditorSettle, so that it stops once the shape no longer changes visibly (a twist's energy falls
/// slowly for hundreds of iterations, each moving the shape by a fraction of a pixel).
struct RefinementOptions {
  bool accelerate = true;    ///< Anderson acceleration of the positions (Peng et al. 2018)
  int history = 3;           ///< iterations it mixes, 1 to kMaxRefinementHistory (1 to 8 converge alike here)
  double tolerance = 1e-6;   ///< converged: E falls by less than this fraction in an iteration
  /// Settled (> 0: on): a plain iteration from the current state would move no vertex by more than
  /// this fraction of the rest shape's bounding-box diagonal.
  double settle = 0.0;
  int max_iterations = 1000; ///< the cap of a run "until converged"
};

/// The most earlier iterations the accelerator may mix.
inline constexpr int kMaxRefinementHistory = 8;
/// The editor's settle test: a tenth of a pixel where the default view shows the bounding box's
/// diagonal 700 pixels long (a 1200×700 window).
inline constexpr double kEditorSettle = 1e-4;

/// Where an edit's refinement starts. From the paper's result, the outcome is a function of the
/// pose alone: the same bits as a fresh Deformer's, whatever came before. From the last edit (a
/// drag shown live, step after step), it starts from that edit's refined rotations, turned by the
/// change of the paper's field: fewer iterations for a small step, but the outcome depends on the
/// path the drag took.
enum class RefinementStart { FromPapersResult, FromLastEdit };

/// Where a refinement run stands: its iterations, energies and why it stopped.
struct RefinementStatus {
  int iterations = 0;             ///< since the last deform()
  double energy = 0.0;            ///< after the last iteration
  double unrefined_energy = 0.0;  ///< of the paper's result (rotations fitted to it)
  bool converged = false;         ///< by either test of RefinementOptions
  bool settled = false;           ///< ... by the settle test
  /// The largest vertex move a plain iteration from the state before the last iteration would
  /// make, as a fraction of the rest shape's bounding-box diagonal (what the settle test reads).
  double largest_step = 0.0;
  int accelerated = 0;            ///< iterations whose accelerated step was kept
  int rejected = 0;               ///< ... that fell back to the plain step (the energy would have risen)
  bool started_from_paper = false;  ///< a start from the last edit did worse than the paper's result and was dropped
};

/// Where the last refinement iteration's time went, milliseconds per stage.
struct RefinementTimings {
  double rhs_ms = 0.0;           ///< right-hand side from the rotations
  double solve_ms = 0.0;         ///< back-substitution
  double acceleration_ms = 0.0;  ///< Anderson mixing
  double rotations_ms = 0.0;     ///< local step: covariances, rotation fits, energy
  double total_ms = 0.0;
};

}  // namespace hdeform

#pragma once
/// @file
/// Deformation transfer (paper §6 and §7): the poses of a source mesh copied onto a target mesh
/// from marker pairs, by one of two methods.
///
///   correspondence (§6): harmonic coordinates on both meshes (k fields each, one factorization
///     per mesh); every target triangle takes the deformation gradient of the source triangle
///     with the nearest coordinate. A target triangle whose nearest source coordinate is farther
///     than the mismatch threshold is a mismatch: its deformation is interpolated harmonically
///     (rotation as a quaternion, stretch as a symmetric matrix) from the matched triangles
///     around it.
///   interpolation (§7): no correspondence beyond the markers. The deformation at each source
///     marker (the area-weighted mean gradient of its triangles, as a unit quaternion and a scale)
///     is a Dirichlet value at its target marker; q0..q3 and s are interpolated harmonically over
///     the target, quaternions normalised, and each triangle deformed by the value at its
///     barycenter.
///
/// Either way the target is rebuilt by the Poisson solve of paper §5 with one vertex pinned per
/// connected component (the first marker in it), and then placed: translated so that the mean of
/// its markers moves as the mean of the source markers did, scaled by the ratio of the two marker
/// sets' spreads. Everything that does not depend on the pose — factorizations, coordinates,
/// matching — is done once, so each pose of a sequence costs right-hand sides and
/// back-substitution.
#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hdeform/correspondence.h"
#include "hdeform/deformer.h"
#include "hdeform/marker_io.h"
#include "hdeform/mesh.h"
#include "hdeform/sparse_cholesky.h"

namespace hdeform {

/// Deformation transfer's two methods: matched triangles (§6) or interpolated marker deformations (§7).
enum class TransferMethod { Correspondence, Interpolation };
/// The method's name: "correspondence", "interpolation".
std::string_view to_string(TransferMethod method);
/// The method named `name`, or nullopt.
std::optional<TransferMethod> parse_transfer_method(std::string_view name);

/// Harmonic coordinates lie in [0, 1]^k; a target triangle and its nearest source triangle are
/// typically a few hundredths apart (lion → cat, 55 markers: median 0.034, 95th percentile 0.091,
/// largest 0.30). Farther than this, a target triangle is taken to have no counterpart (24 of the
/// cat's 14,410 triangles; at 0.1 it would be 517, and the recovered cat poses slightly worse).
inline constexpr double kDefaultMismatchThreshold = 0.2;

/// How a DeformationTransfer is set up.
struct TransferOptions {
  TransferMethod method = TransferMethod::Correspondence;
  int top_n = 0;  ///< correspondence: compare only this many largest components (0: all k)
  double mismatch_threshold = kDefaultMismatchThreshold;  ///< correspondence
  SolverBackend backend = default_backend();
  FactorPrecision precision = FactorPrecision::Double;  ///< how every factor is stored (SparseCholesky::factor)
};

/// Where the set-up's time went, milliseconds per stage.
struct TransferSetupTimings {
  double source_coordinates_ms = 0.0;  ///< correspondence: Laplacian, factorization, k columns
  double target_coordinates_ms = 0.0;  ///< correspondence: the same on the target
  double matching_ms = 0.0;            ///< correspondence: nearest coordinates
  double mismatch_ms = 0.0;            ///< correspondence: the system that fills mismatches
  double marker_fields_ms = 0.0;       ///< interpolation: the target's factorization with the markers fixed
  double reconstruction_ms = 0.0;      ///< the target's Poisson system (factorization, assembler)
  double total_ms = 0.0;
};

/// Where the last pose's time went, milliseconds per stage.
struct TransferPoseTimings {
  double gradients_ms = 0.0;       ///< source deformation gradients
  double fields_ms = 0.0;          ///< interpolated fields (§7) or mismatch fill (§6)
  double reconstruction_ms = 0.0;  ///< right-hand side, solve and placement
  double total_ms = 0.0;
};

/// Copies poses of a source mesh onto a target mesh from marker pairs (paper §6, §7): set up once
/// (coordinates, matching, factorizations), then transfer() per pose.
class DeformationTransfer {
 public:
  // Throws InputError for markers out of range and SolveError when a factorization fails.
  /// Sets up the transfer: checks the meshes and markers, solves the coordinates, matches the
  /// triangles (correspondence) and factors the target's systems; `progress` before each stage.
  DeformationTransfer(Mesh source_rest, Mesh target_rest, MarkerPairs markers, TransferOptions options = {},
                      const ProgressCallback& progress = {});
  ~DeformationTransfer();
  DeformationTransfer(const DeformationTransfer&) = delete;
  DeformationTransfer& operator=(const DeformationTransfer&) = delete;

  /// The target's positions (resized to n_t × 3) for a pose of the source: `source_pose` holds the
  /// source's vertex positions (its rest connectivity). Throws InputError for a wrong vertex count.
  void transfer(const Eigen::MatrixXd& source_pose, Eigen::MatrixXd& target_positions);

  /// The source's rest mesh.
  const Mesh& source_rest() const { return source_rest_; }
  /// The target's rest mesh.
  const Mesh& target_rest() const { return target_rest_; }
  /// The marker pairs.
  const MarkerPairs& markers() const { return markers_; }
  /// The options it was made with.
  const TransferOptions& options() const { return options_; }

  /// Correspondence: the source triangle each target triangle takes its deformation from, and
  /// which target triangles are mismatches. Empty for interpolation.
  const TriangleMatch& match() const { return match_; }
  /// Per target triangle: true when it had no counterpart closer than the mismatch threshold.
  const std::vector<bool>& mismatched() const { return mismatched_; }
  /// The number of mismatched target triangles.
  std::size_t mismatch_count() const;

  /// Factorizations made so far: each matrix is factored once, however many poses follow.
  std::size_t factorizations() const { return factorizations_; }
  /// Of them, the factors kept in single precision (TransferOptions::precision).
  std::size_t single_precision_factorizations() const { return single_precision_factorizations_; }
  /// Where the set-up's time went.
  const TransferSetupTimings& setup_timings() const { return setup_; }
  /// Where the last pose's time went.
  const TransferPoseTimings& last_pose() const { return last_pose_; }
  /// Findings the user should know about (stray components, mismatches).
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  struct Reconstruction;
  struct MarkerFields;
  struct MismatchFill;

  /// A mesh's cotangent weights, its Laplacian and the AMD order of the whole Laplacian that every
  /// system on the mesh eliminates in: computed once per mesh (the target has up to three systems).
  struct Operators;
  /// Partitions with `fixed` (sorted) as the fixed vertices and factors L_ff; counts it.
  std::unique_ptr<DirichletSystem> factor(const Mesh& mesh, const Operators& operators, const std::vector<int>& fixed, VertexPartition& partition);
  void setup_correspondence(const Operators& source_operators, const ProgressCallback& progress);
  void setup_interpolation();
  void fill_mismatches();
  void interpolate_marker_fields(const Eigen::MatrixXd& source_pose);
  void reconstruct_and_place(const Eigen::MatrixXd& source_pose, Eigen::MatrixXd& target_positions);

  Mesh source_rest_;
  Mesh target_rest_;
  MarkerPairs markers_;
  TransferOptions options_;
  std::unique_ptr<Operators> target_operators_;
  TriangleMatch match_;
  std::vector<bool> mismatched_;
  std::unique_ptr<Reconstruction> reconstruction_;
  std::unique_ptr<MarkerFields> marker_fields_;
  std::unique_ptr<MismatchFill> mismatch_fill_;
  std::vector<Eigen::Matrix3d> source_gradients_;
  std::vector<Eigen::Matrix3d> target_maps_;
  std::size_t factorizations_ = 0;
  std::size_t single_precision_factorizations_ = 0;
  TransferSetupTimings setup_;
  TransferPoseTimings last_pose_;
  std::vector<std::string> warnings_;
};

/// How far a result is from an expected mesh with the same vertices: the RMS vertex distance after
/// the best rigid alignment of the result onto the expected mesh (Kabsch), divided by the expected
/// mesh's bounding-box diagonal.
double aligned_rms_error(const Eigen::MatrixXd& result, const Eigen::MatrixXd& expected);

}  // namespace hdeform

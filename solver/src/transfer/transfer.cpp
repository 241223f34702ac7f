#include "hdeform/transfer.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <optional>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include "mesh/disjoint_sets.h"
#include "hdeform/constraints.h"
#include "hdeform/counted.h"
#include "hdeform/deformation_field.h"
#include "hdeform/deformation_gradient.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/errors.h"
#include "hdeform/trace.h"
#include "hdeform/harmonic_coordinates.h"
#include "hdeform/laplacian.h"
#include "hdeform/poisson.h"
#include "hdeform/sparse_cholesky.h"
#include "hdeform/stopwatch.h"

namespace hdeform {
namespace {

using Clock = std::chrono::steady_clock;

void check_markers(const std::vector<int>& vertices, Eigen::Index vertex_count, const char* mesh) {
  std::vector<int> first(static_cast<std::size_t>(vertex_count), -1);
  for (std::size_t j = 0; j < vertices.size(); ++j) {
    if (vertices[j] < 0 || vertices[j] >= vertex_count) {
      throw InputError("marker " + std::to_string(j + 1) + ": " + mesh + " vertex " + std::to_string(vertices[j]) + " out of range (the " + mesh +
                       " mesh has " + std::to_string(vertex_count) + " vertices)");
    }
    int& seen = first[static_cast<std::size_t>(vertices[j])];
    if (seen >= 0) {
      throw InputError("markers " + std::to_string(seen + 1) + " and " + std::to_string(j + 1) + " share the " + mesh + " vertex " +
                       std::to_string(vertices[j]));
    }
    seen = static_cast<int>(j);
  }
}

Eigen::Vector3d mean_of(const Eigen::MatrixXd& positions, const std::vector<int>& vertices) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const int v : vertices) sum += positions.row(v).transpose();
  return sum / static_cast<double>(vertices.size());
}

double spread_of(const Eigen::MatrixXd& positions, const std::vector<int>& vertices) {
  const Eigen::Vector3d centre = mean_of(positions, vertices);
  double sum = 0.0;
  for (const int v : vertices) sum += (positions.row(v).transpose() - centre).squaredNorm();
  return std::sqrt(sum / static_cast<double>(vertices.size()));
}

// Flips quaternions (rows of `q`, columns w x y z) into the hemisphere of their principal
// direction (the eigenvector of Σ q qᵀ with the largest eigenvalue), so that interpolating the
// components blends neighbouring rotations the short way round whatever the overall turn.
void align_hemisphere(Eigen::Ref<Eigen::MatrixXd> q) {
  if (q.rows() == 0) return;
  const Eigen::Matrix4d scatter = q.transpose() * q;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eigen(scatter);
  const Eigen::Vector4d principal = eigen.eigenvectors().col(3);
  for (Eigen::Index r = 0; r < q.rows(); ++r) {
    if (q.row(r).dot(principal) < 0.0) q.row(r) = -q.row(r);
  }
}

Eigen::Vector4d as_vector(const Eigen::Quaterniond& q) { return {q.w(), q.x(), q.y(), q.z()}; }
Eigen::Quaterniond unit_quaternion(const Eigen::Vector4d& v) {
  const double length = v.norm();
  if (!(length > 1e-12)) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(v(0) / length, v(1) / length, v(2) / length, v(3) / length);
}

// A deformation as 10 numbers: rotation quaternion and symmetric stretch (polar Q = R S).
constexpr int kPolarComponents = 10;
Eigen::Matrix<double, 1, kPolarComponents> polar_components(const Eigen::Matrix3d& deformation) {
  const RotationScale rotation_scale = rotation_and_scale(deformation);
  const Eigen::Matrix3d stretch = rotation_scale.rotation.toRotationMatrix().transpose() * deformation;
  Eigen::Matrix<double, 1, kPolarComponents> row;
  row << as_vector(rotation_scale.rotation).transpose(), stretch(0, 0), stretch(1, 1), stretch(2, 2), 0.5 * (stretch(0, 1) + stretch(1, 0)),
      0.5 * (stretch(0, 2) + stretch(2, 0)), 0.5 * (stretch(1, 2) + stretch(2, 1));
  return row;
}
Eigen::Matrix3d from_polar_components(const Eigen::Matrix<double, 1, kPolarComponents>& row) {
  Eigen::Matrix3d stretch;
  stretch << row(4), row(7), row(8), row(7), row(5), row(9), row(8), row(9), row(6);
  return unit_quaternion(row.head<4>().transpose()).toRotationMatrix() * stretch;
}

}  // namespace

std::string_view to_string(TransferMethod method) {
  return method == TransferMethod::Correspondence ? "correspondence" : "interpolation";
}

std::optional<TransferMethod> parse_transfer_method(std::string_view name) {
  if (name == "correspondence") return TransferMethod::Correspondence;
  if (name == "interpolation") return TransferMethod::Interpolation;
  return std::nullopt;
}

struct DeformationTransfer::Operators {
  Operators(const Mesh& mesh, SolverBackend backend) : weights(cotangent_weights(mesh)), laplacian(cotangent_laplacian(mesh, weights)) {
    if (backend == SolverBackend::Tree) elimination_rank = elimination_ranks(laplacian);
  }
  CotangentWeights weights;
  Eigen::SparseMatrix<double> laplacian;
  std::vector<int> elimination_rank;  // empty for a backend that orders by itself
};

// The target's Poisson system: one vertex pinned per connected component.
struct DeformationTransfer::Reconstruction {
  VertexPartition partition;
  std::unique_ptr<DirichletSystem> system;
  std::unique_ptr<PoissonAssembler> assembler;
};

// §7: the target's Laplacian with the markers fixed, and where each source marker's deformation
// is read (its triangles and their areas).
struct DeformationTransfer::MarkerFields {
  VertexPartition partition;
  std::unique_ptr<DirichletSystem> system;
  std::vector<std::vector<std::pair<int, double>>> source_triangles;  // per marker: (triangle, area)
  Eigen::MatrixXd values;                                             // n_t × 5, reused per pose
  Eigen::Matrix<double, Eigen::Dynamic, kInterpolatedComponents, Eigen::RowMajor> components;
};

// §6: the target's Laplacian with every vertex that touches a matched triangle fixed (to the
// mean of those triangles' deformations); the rest, inside mismatched regions, is interpolated.
struct DeformationTransfer::MismatchFill {
  VertexPartition partition;
  std::unique_ptr<DirichletSystem> system;
  std::vector<std::vector<int>> matched_triangles;  // per vertex
  // The known vertices whose values matter: coupled to an interpolated one, or a corner of a
  // mismatched triangle (most known vertices are neither, and need no polar decomposition).
  std::vector<int> needed;
  Eigen::MatrixXd values;  // n_t × 10, reused per pose
};

DeformationTransfer::DeformationTransfer(Mesh source_rest, Mesh target_rest, MarkerPairs markers, TransferOptions options,
                                         const ProgressCallback& progress)
    : source_rest_(std::move(source_rest)), target_rest_(std::move(target_rest)), markers_(std::move(markers)), options_(options) {
  const auto start = Clock::now();
  const auto report = [&](std::string_view stage) {
    if (progress) progress(stage);
  };
  validate_mesh(source_rest_, "source mesh");
  validate_mesh(target_rest_, "target mesh");
  if (markers_.source.size() != markers_.target.size()) throw InputError("markers: the source and target lists differ in length");
  if (markers_.size() < kMinimumMarkers) {
    throw InputError(std::to_string(markers_.size()) + " marker pair(s); deformation transfer needs at least " + std::to_string(kMinimumMarkers));
  }
  check_markers(markers_.source, source_rest_.vertex_count(), "source");
  check_markers(markers_.target, target_rest_.vertex_count(), "target");
  if (options_.method == TransferMethod::Correspondence && options_.top_n != 0 &&
      (options_.top_n < 3 || options_.top_n > static_cast<int>(markers_.size()))) {
    throw InputError("--top-n must be between 3 and the number of markers (" + std::to_string(markers_.size()) + "), got " +
                     std::to_string(options_.top_n));
  }
  if (!(options_.mismatch_threshold > 0.0)) throw InputError("the mismatch threshold must be positive");

  const bool correspondence = options_.method == TransferMethod::Correspondence;
  std::unique_ptr<Operators> source_operators;
  tbb::parallel_invoke(
      [&] {
        const trace::Scope traced("target operators (weights, Laplacian, elimination order)", "set-up");
        target_operators_ = std::make_unique<Operators>(target_rest_, options_.backend);
      },
      [&] {
        if (!correspondence) return;
        const trace::Scope traced("source operators (weights, Laplacian, elimination order)", "set-up");
        source_operators = std::make_unique<Operators>(source_rest_, options_.backend);
      });
  if (correspondence) setup_correspondence(*source_operators, progress);
  else setup_interpolation();
  const CotangentWeights& target_weights = target_operators_->weights;

  // The Poisson system: the first marker of each connected component pinned.
  report("factoring the target's Poisson system");
  const trace::Scope traced("target Poisson system", "set-up");
  auto reconstruction_start = Clock::now();
  detail::DisjointSets components(static_cast<std::size_t>(target_rest_.vertex_count()));
  for (Eigen::Index t = 0; t < target_rest_.triangle_count(); ++t) {
    if (target_weights.kind[static_cast<std::size_t>(t)] != ElementKind::Regular) continue;
    components.unite(target_rest_.triangles(t, 0), target_rest_.triangles(t, 1));
    components.unite(target_rest_.triangles(t, 0), target_rest_.triangles(t, 2));
  }
  std::vector<int> pins;
  std::vector<int> pinned_components;
  for (const int v : markers_.target) {
    const int component = components.find(v);
    if (std::find(pinned_components.begin(), pinned_components.end(), component) != pinned_components.end()) continue;
    pinned_components.push_back(component);
    pins.push_back(v);
  }
  std::sort(pins.begin(), pins.end());
  reconstruction_ = std::make_unique<Reconstruction>();
  reconstruction_->system = factor(target_rest_, *target_operators_, pins, reconstruction_->partition);
  if (reconstruction_->partition.stray_components > 0) {
    const std::size_t stray = reconstruction_->partition.stray_components;
    warnings_.push_back(counted(stray, "part", "parts") + " of the target" +
                        (stray == 1 ? " holds no marker and stays where it is" : " hold no marker and stay where they are"));
  }
  reconstruction_->assembler = std::make_unique<PoissonAssembler>(target_rest_, target_weights, *reconstruction_->system);
  target_maps_.assign(static_cast<std::size_t>(target_rest_.triangle_count()), Eigen::Matrix3d::Identity());
  setup_.reconstruction_ms = milliseconds_since(reconstruction_start);
  setup_.total_ms = milliseconds_since(start);
}

DeformationTransfer::~DeformationTransfer() = default;

std::unique_ptr<DirichletSystem> DeformationTransfer::factor(const Mesh& mesh, const Operators& operators, const std::vector<int>& fixed,
                                                             VertexPartition& partition) {
  EditConstraints constraints;
  constraints.fixed = fixed;
  partition = partition_vertices(mesh, operators.weights, constraints);
  auto system = std::make_unique<DirichletSystem>(operators.laplacian, partition, options_.backend, operators.elimination_rank,
                                                  nullptr, options_.precision);
  ++factorizations_;
  if (system->factor().precision() == FactorPrecision::Single) ++single_precision_factorizations_;
  const std::string& note = system->factor().precision_note();
  if (!note.empty() && std::find(warnings_.begin(), warnings_.end(), note) == warnings_.end()) warnings_.push_back(note);
  return system;
}

void DeformationTransfer::setup_correspondence(const Operators& source_operators, const ProgressCallback& progress) {
  const auto report = [&](std::string_view stage) {
    if (progress) progress(stage);
  };
  const auto k = markers_.size();
  auto coordinates = [&](const Mesh& mesh, const Operators& operators, const std::vector<int>& markers, const char* which) {
    report(std::string("harmonic coordinates on the ") + which + " (" + std::to_string(k) + " fields)");
    std::vector<int> fixed = markers;
    std::sort(fixed.begin(), fixed.end());
    VertexPartition partition;
    const auto system = factor(mesh, operators, fixed, partition);
    if (partition.stray_components > 0) {
      const bool one = partition.stray_components == 1;
      warnings_.push_back(counted(partition.stray_components, "part", "parts") + " of the " + which +
                          (one ? " holds no marker: its triangles all have the same coordinate"
                               : " hold no marker: their triangles all have the same coordinate"));
    }
    return VertexCoordinates(*system, partition, markers);
  };
  // Neither mesh's triangle coordinates are written out: the search forms a triangle's row from
  // its corners' where it needs one (horse → camel with 124 markers: 60 MB never written).
  auto start = Clock::now();
  std::optional<trace::Scope> traced;
  traced.emplace("source harmonic coordinates", "set-up");
  const VertexCoordinates source_coordinates = coordinates(source_rest_, source_operators, markers_.source, "source");
  setup_.source_coordinates_ms = milliseconds_since(start);
  start = Clock::now();
  traced.emplace("target harmonic coordinates", "set-up");
  const VertexCoordinates target_coordinates = coordinates(target_rest_, *target_operators_, markers_.target, "target");
  setup_.target_coordinates_ms = milliseconds_since(start);

  report("matching triangles");
  start = Clock::now();
  traced.emplace("matching", "set-up");
  match_ = match_triangles(target_coordinates, target_rest_.triangles, source_coordinates, source_rest_.triangles, options_.top_n);
  mismatched_.resize(match_.source.size());
  for (std::size_t t = 0; t < mismatched_.size(); ++t) mismatched_[t] = !(match_.distance[t] <= options_.mismatch_threshold);
  setup_.matching_ms = milliseconds_since(start);
  traced.emplace("mismatch fill system", "set-up");

  const std::size_t mismatches = mismatch_count();
  if (mismatches == 0) return;
  warnings_.push_back(std::to_string(mismatches) + " of " + std::to_string(mismatched_.size()) +
                      " target triangles have no source triangle within the mismatch threshold: their deformation is interpolated");
  report("factoring the mismatch fill");
  start = Clock::now();
  mismatch_fill_ = std::make_unique<MismatchFill>();
  auto& fill = *mismatch_fill_;
  fill.matched_triangles.resize(static_cast<std::size_t>(target_rest_.vertex_count()));
  for (Eigen::Index t = 0; t < target_rest_.triangle_count(); ++t) {
    if (mismatched_[static_cast<std::size_t>(t)]) continue;
    for (int c = 0; c < 3; ++c) fill.matched_triangles[static_cast<std::size_t>(target_rest_.triangles(t, c))].push_back(static_cast<int>(t));
  }
  std::vector<int> known;
  for (std::size_t v = 0; v < fill.matched_triangles.size(); ++v) {
    if (!fill.matched_triangles[v].empty()) known.push_back(static_cast<int>(v));
  }
  if (known.empty()) throw InputError("no target triangle matches a source triangle within the mismatch threshold: place markers on corresponding parts");
  fill.system = factor(target_rest_, *target_operators_, known, fill.partition);
  std::vector<bool> needed(static_cast<std::size_t>(target_rest_.vertex_count()), false);
  for (Eigen::Index row = 0; row < fill.system->free_count(); ++row) {
    for (const auto& entry : fill.system->coupling(static_cast<int>(row))) needed[static_cast<std::size_t>(entry.vertex)] = true;
  }
  for (Eigen::Index t = 0; t < target_rest_.triangle_count(); ++t) {
    if (!mismatched_[static_cast<std::size_t>(t)]) continue;
    for (int c = 0; c < 3; ++c) {
      const int v = target_rest_.triangles(t, c);
      if (fill.partition.role[static_cast<std::size_t>(v)] != VertexRole::Free) needed[static_cast<std::size_t>(v)] = true;
    }
  }
  for (std::size_t v = 0; v < needed.size(); ++v) {
    if (needed[v]) fill.needed.push_back(static_cast<int>(v));
  }
  fill.values = Eigen::MatrixXd::Zero(target_rest_.vertex_count(), kPolarComponents);
  setup_.mismatch_ms = milliseconds_since(start);
}

void DeformationTransfer::setup_interpolation() {
  const trace::Scope traced("marker fields", "set-up");
  const auto start = Clock::now();
  marker_fields_ = std::make_unique<MarkerFields>();
  auto& fields = *marker_fields_;
  std::vector<int> fixed = markers_.target;
  std::sort(fixed.begin(), fixed.end());
  fields.system = factor(target_rest_, *target_operators_, fixed, fields.partition);
  fields.source_triangles.resize(markers_.size());
  std::vector<int> marker_of_vertex(static_cast<std::size_t>(source_rest_.vertex_count()), -1);
  for (std::size_t j = 0; j < markers_.size(); ++j) marker_of_vertex[static_cast<std::size_t>(markers_.source[j])] = static_cast<int>(j);
  for (Eigen::Index t = 0; t < source_rest_.triangle_count(); ++t) {
    const Eigen::Vector3d a = source_rest_.positions.row(source_rest_.triangles(t, 0));
    const Eigen::Vector3d b = source_rest_.positions.row(source_rest_.triangles(t, 1));
    const Eigen::Vector3d c = source_rest_.positions.row(source_rest_.triangles(t, 2));
    const double area = 0.5 * (b - a).cross(c - a).norm();
    if (!(area > 0.0)) continue;
    for (int corner = 0; corner < 3; ++corner) {
      const int marker = marker_of_vertex[static_cast<std::size_t>(source_rest_.triangles(t, corner))];
      if (marker >= 0) fields.source_triangles[static_cast<std::size_t>(marker)].emplace_back(static_cast<int>(t), area);
    }
  }
  for (std::size_t j = 0; j < markers_.size(); ++j) {
    if (fields.source_triangles[j].empty()) {
      throw InputError("marker " + std::to_string(j + 1) + ": source vertex " + std::to_string(markers_.source[j]) +
                       " belongs to no triangle with an area, so it has no deformation");
    }
  }
  if (fields.partition.stray_components > 0) {
    const bool one = fields.partition.stray_components == 1;
    warnings_.push_back(counted(fields.partition.stray_components, "part", "parts") + " of the target" +
                        (one ? " holds no marker and is not deformed" : " hold no marker and are not deformed"));
  }
  fields.values.resize(target_rest_.vertex_count(), kInterpolatedComponents);
  fields.components.resize(target_rest_.vertex_count(), kInterpolatedComponents);
  setup_.marker_fields_ms = milliseconds_since(start);
}

std::size_t DeformationTransfer::mismatch_count() const {
  return static_cast<std::size_t>(std::count(mismatched_.begin(), mismatched_.end(), true));
}

void DeformationTransfer::transfer(const Eigen::MatrixXd& source_pose, Eigen::MatrixXd& target_positions) {
  if (source_pose.rows() != source_rest_.vertex_count() || source_pose.cols() != 3) {
    throw InputError("the pose has " + std::to_string(source_pose.rows()) + " vertices; the source rest mesh has " +
                     std::to_string(source_rest_.vertex_count()));
  }
  if (!source_pose.allFinite()) throw InputError("the pose has a non-finite coordinate");
  const trace::Scope traced_pose("pose", "transfer");
  const auto start = Clock::now();
  last_pose_ = TransferPoseTimings{};
  auto stage = Clock::now();
  if (options_.method == TransferMethod::Correspondence) {
    const trace::Scope traced("gradients and mismatch fill", "transfer");
    deformation_gradients(source_rest_, source_pose, source_gradients_);
    tbb::parallel_for(std::size_t{0}, target_maps_.size(), [&](std::size_t t) {
      if (!mismatched_[t]) target_maps_[t] = source_gradients_[static_cast<std::size_t>(match_.source[t])];
    });
    last_pose_.gradients_ms = milliseconds_since(stage);
    stage = Clock::now();
    if (mismatch_fill_) fill_mismatches();
    last_pose_.fields_ms = milliseconds_since(stage);
  } else {
    interpolate_marker_fields(source_pose);
  }
  stage = Clock::now();
  const trace::Scope traced("reconstruction and placement", "transfer");
  reconstruct_and_place(source_pose, target_positions);
  last_pose_.reconstruction_ms = milliseconds_since(stage);
  last_pose_.total_ms = milliseconds_since(start);
}

void DeformationTransfer::fill_mismatches() {
  auto& fill = *mismatch_fill_;
  const auto needed = static_cast<Eigen::Index>(fill.needed.size());
  Eigen::MatrixXd rotations(needed, 4);
  for (Eigen::Index r = 0; r < needed; ++r) {
    const int v = fill.needed[static_cast<std::size_t>(r)];
    const auto& triangles = fill.matched_triangles[static_cast<std::size_t>(v)];
    if (triangles.empty()) {
      // Fixed by the partition in a part without any match: the identity.
      fill.values.row(v) << 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0;
    } else {
      Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
      for (const int t : triangles) sum += target_maps_[static_cast<std::size_t>(t)];
      fill.values.row(v) = polar_components(sum / static_cast<double>(triangles.size()));
    }
    rotations.row(r) = fill.values.row(v).head<4>();
  }
  align_hemisphere(rotations);
  for (Eigen::Index r = 0; r < needed; ++r) fill.values.row(fill.needed[static_cast<std::size_t>(r)]).head<4>() = rotations.row(r);
  fill.system->solve(fill.values);
  for (Eigen::Index t = 0; t < target_rest_.triangle_count(); ++t) {
    if (!mismatched_[static_cast<std::size_t>(t)]) continue;
    const Eigen::Matrix<double, 1, kPolarComponents> mean =
        (fill.values.row(target_rest_.triangles(t, 0)) + fill.values.row(target_rest_.triangles(t, 1)) + fill.values.row(target_rest_.triangles(t, 2))) / 3.0;
    target_maps_[static_cast<std::size_t>(t)] = from_polar_components(mean);
  }
}

void DeformationTransfer::interpolate_marker_fields(const Eigen::MatrixXd& source_pose) {
  auto& fields = *marker_fields_;
  auto stage = Clock::now();
  const auto k = static_cast<Eigen::Index>(markers_.size());
  Eigen::MatrixXd rotations(k, 4);
  Eigen::VectorXd scales(k);
  for (Eigen::Index j = 0; j < k; ++j) {
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
    double total_area = 0.0;
    for (const auto& [t, area] : fields.source_triangles[static_cast<std::size_t>(j)]) {
      const auto& tri = source_rest_.triangles;
      sum += area * deformation_gradient(source_rest_.positions.row(tri(t, 0)).transpose(), source_rest_.positions.row(tri(t, 1)).transpose(),
                                         source_rest_.positions.row(tri(t, 2)).transpose(), source_pose.row(tri(t, 0)).transpose(),
                                         source_pose.row(tri(t, 1)).transpose(), source_pose.row(tri(t, 2)).transpose());
      total_area += area;
    }
    const RotationScale rotation_scale = rotation_and_scale(sum / total_area);
    rotations.row(j) = as_vector(rotation_scale.rotation).transpose();
    scales(j) = rotation_scale.scale;
  }
  align_hemisphere(rotations);
  last_pose_.gradients_ms = milliseconds_since(stage);
  stage = Clock::now();
  // Constrained vertices other than markers (parts without one) hold the identity.
  for (Eigen::Index v = 0; v < fields.values.rows(); ++v) {
    if (fields.partition.role[static_cast<std::size_t>(v)] != VertexRole::Free) fields.values.row(v) = identity_interpolation_value();
  }
  for (Eigen::Index j = 0; j < k; ++j) {
    fields.values.row(markers_.target[static_cast<std::size_t>(j)]) << rotations.row(j), scales(j);
  }
  fields.system->solve(fields.values);
  fields.components = fields.values;
  sample_interpolated_maps(fields.components, target_rest_.triangles, target_maps_);
  last_pose_.fields_ms = milliseconds_since(stage);
}

void DeformationTransfer::reconstruct_and_place(const Eigen::MatrixXd& source_pose, Eigen::MatrixXd& target_positions) {
  target_positions = target_rest_.positions;  // the pinned vertices and parts without markers keep their rest positions
  poisson_reconstruct(*reconstruction_->assembler, *reconstruction_->system, target_maps_, target_positions);
  const double scale = spread_of(target_rest_.positions, markers_.target) / spread_of(source_rest_.positions, markers_.source);
  const Eigen::Vector3d source_motion = mean_of(source_pose, markers_.source) - mean_of(source_rest_.positions, markers_.source);
  const Eigen::Vector3d target_motion = mean_of(target_positions, markers_.target) - mean_of(target_rest_.positions, markers_.target);
  target_positions.rowwise() += (scale * source_motion - target_motion).transpose();
}

double aligned_rms_error(const Eigen::MatrixXd& result, const Eigen::MatrixXd& expected) {
  if (result.rows() != expected.rows() || result.cols() != 3 || expected.cols() != 3) {
    throw std::invalid_argument("aligned_rms_error: the meshes differ in vertex count");
  }
  const Eigen::RowVector3d result_centre = result.colwise().mean();
  const Eigen::RowVector3d expected_centre = expected.colwise().mean();
  const Eigen::MatrixXd a = result.rowwise() - result_centre;
  const Eigen::MatrixXd b = expected.rowwise() - expected_centre;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a.transpose() * b, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d correction = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) correction(2, 2) = -1.0;
  const Eigen::Matrix3d rotation = svd.matrixV() * correction * svd.matrixU().transpose();  // maps a onto b
  const Eigen::MatrixXd aligned = a * rotation.transpose();
  const double rms = std::sqrt((aligned - b).rowwise().squaredNorm().mean());
  const double diagonal = (expected.colwise().maxCoeff() - expected.colwise().minCoeff()).norm();
  return rms / diagonal;
}

}  // namespace hdeform

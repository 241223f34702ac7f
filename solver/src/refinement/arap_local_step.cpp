// The refinement's local step (arap_refinement.h): each rotation vertex's covariance gathered
// over its pairs with its share of the energy, the rotations fitted to them, and the fit's
// bookkeeping (the turn limit, the fall back to the plain step).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <span>

#include "arap_refinement.h"
#include "arap_stages.h"
#include "hdeform/rotation_fit.h"
#include "hdeform/stopwatch.h"
#include "lanes.h"
#include "rotation_newton.h"
#include "target_clones.h"

namespace hdeform::detail {
namespace {

using Clock = std::chrono::steady_clock;

// The local step's matrix A_i = Σ_v p'_v k_ivᵀ of rotation vertex i as three columns, the rows of
// positions (x, y, z, pad) in the lanes, each entry the sum of its products in pair order, as a
// scalar loop would add them; beside it the vertex's share of the deformed edges' energy,
// Σ_v W_iv ‖p'_v − p'_i‖², from the rows already loaded.
template <class Coefficient>
[[gnu::always_inline]] inline void gather_covariance(const std::size_t* pair_start, const int* pair_vertex, const Coefficient* coefficient,
                                                     const double* positions, std::size_t i, Lanes4 (&column)[3], double& edge_energy) {
  // (Sums in locals, not in `column`: summed where the caller's array is, they stayed in memory.)
  Lanes4 sum0 = {}, sum1 = {}, sum2 = {}, energy = {}, self;
  load_lanes(positions + kStride * i, self);
  for (std::size_t p = pair_start[i]; p < pair_start[i + 1]; ++p) {
    __builtin_prefetch(positions + kStride * static_cast<std::size_t>(pair_vertex[p + kPairsAhead]));
    Lanes4 position, c;
    load_lanes(positions + kStride * static_cast<std::size_t>(pair_vertex[p]), position);
    load_lanes(coefficient[p].values.data(), c);  // k_iv and W_iv
    sum0 += position * c[0];
    sum1 += position * c[1];
    sum2 += position * c[2];
    const Lanes4 edge = position - self;
    energy += (edge * edge) * c[3];
  }
  column[0] = sum0;
  column[1] = sum1;
  column[2] = sum2;
  edge_energy = (energy[0] + energy[1]) + energy[2];  // the pad lane is zero
}

// The matrices A_i of the rotation vertices [first, first + count), for fits that look at them
// one by one (the turn limit).
template <class Coefficient>
HDEFORM_TARGET_CLONES("avx2", "default")
void gather_covariances(const std::size_t* pair_start, const int* pair_vertex, const Coefficient* coefficient, const double* positions,
                        std::size_t first, std::size_t count, Eigen::Matrix3d* covariance, double* edge_energy) {
  for (std::size_t k = 0; k < count; ++k) {
    Lanes4 column[3];
    gather_covariance(pair_start, pair_vertex, coefficient, positions, first + k, column, edge_energy[k]);
    double* out = covariance[k].data();  // column-major
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) out[3 * j + i] = column[j][i];
    }
  }
}

// Four rows of four lanes as four columns: out[k] holds lane k of each row.
[[gnu::always_inline]] inline void transpose(const Lanes4& r0, const Lanes4& r1, const Lanes4& r2, const Lanes4& r3, Lanes4 (&out)[4]) {
  const Lanes4 low01 = __builtin_shufflevector(r0, r1, 0, 4, 2, 6), high01 = __builtin_shufflevector(r0, r1, 1, 5, 3, 7);
  const Lanes4 low23 = __builtin_shufflevector(r2, r3, 0, 4, 2, 6), high23 = __builtin_shufflevector(r2, r3, 1, 5, 3, 7);
  out[0] = __builtin_shufflevector(low01, low23, 0, 1, 4, 5);
  out[1] = __builtin_shufflevector(high01, high23, 0, 1, 4, 5);
  out[2] = __builtin_shufflevector(low01, low23, 2, 3, 6, 7);
  out[3] = __builtin_shufflevector(high01, high23, 2, 3, 6, 7);
}

// The local step of the rotation vertices [first, first + count) without a turn limit, four at a
// time: their matrices A_i gathered (gather_covariance), turned in registers into the lanes of
// Newton's method (rotation_newton.h) with their starting rotations, fitted, and the rotations
// written back. The bits of hdeform::fit_rotations on the same matrices: only the data's path
// differs (with every matrix copied through memory into the lanes and out, the Buddha's rotation
// stage took 2.48–2.60 ms against 2.08–2.18). objective and edge_energy are indexed from first.
template <class Coefficient>
HDEFORM_TARGET_CLONES("avx2", "default")
void fit_covariances(const std::size_t* pair_start, const int* pair_vertex, const Coefficient* coefficient, const double* positions,
                     const Eigen::Matrix3d* start, std::size_t first, std::size_t count, double tolerance, int steps, Eigen::Matrix3d* rotation,
                     double* objective, double* edge_energy) {
  using rotation_lanes::kLanes;
  for (std::size_t group = 0; group < count; group += kLanes) {
    const std::size_t lanes = std::min<std::size_t>(kLanes, count - group);
    Lanes4 a_column[kLanes][3], start_column[kLanes][3];
    for (std::size_t lane = 0; lane < kLanes; ++lane) {
      // A short group repeats its last vertex in the spare lanes, which are not written back.
      const std::size_t i = first + group + std::min(lane, lanes - 1);
      double energy;
      gather_covariance(pair_start, pair_vertex, coefficient, positions, i, a_column[lane], energy);
      if (lane < lanes) edge_energy[group + lane] = energy;
      const double* r = start[i].data();  // column-major: three overlapping loads within the matrix
      Lanes4 last;
      load_lanes(r, start_column[lane][0]);
      load_lanes(r + 3, start_column[lane][1]);
      load_lanes(r + 5, last);
      start_column[lane][2] = __builtin_shufflevector(last, last, 1, 2, 3, 3);
    }
    rotation_lanes::Matrix3<Lanes4> a, from;
    for (int j = 0; j < 3; ++j) {
      Lanes4 rows[kLanes];
      transpose(a_column[0][j], a_column[1][j], a_column[2][j], a_column[3][j], rows);
      for (int i = 0; i < 3; ++i) a.m[i][j] = rows[i];
      transpose(start_column[0][j], start_column[1][j], start_column[2][j], start_column[3][j], rows);
      for (int i = 0; i < 3; ++i) from.m[i][j] = rows[i];
    }
    rotation_lanes::LaneFit<Lanes4> fit = rotation_lanes::newton(a, from, tolerance, steps);
    for (std::size_t lane = 0; lane < lanes; ++lane) {
      if (fit.needs_svd[lane] == 0) continue;
      Eigen::Matrix3d a_lane;
      RotationFit one;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
          a_lane(i, j) = a.m[i][j][lane];
          one.rotation(i, j) = fit.rotation.m[i][j][lane];
        }
      }
      one.objective = fit.objective[lane];
      rotation_lanes::finish_with_svd(a_lane, one);
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) fit.rotation.m[i][j][lane] = one.rotation(i, j);
      }
      fit.objective[lane] = one.objective;
    }
    Lanes4 columns[3][kLanes];  // columns[j][lane]: column j of the lane's rotation, (x, y, z, 0)
    for (int j = 0; j < 3; ++j) transpose(fit.rotation.m[0][j], fit.rotation.m[1][j], fit.rotation.m[2][j], Lanes4{}, columns[j]);
    for (std::size_t lane = 0; lane < lanes; ++lane) {
      double* out = rotation[first + group + lane].data();
      store_lanes(columns[0][lane], out);      // the pad lands on column 1's first entry, written next
      store_lanes(columns[1][lane], out + 3);  // and this one's on column 2's
      store_lanes(__builtin_shufflevector(columns[1][lane], columns[2][lane], 2, 4, 5, 6), out + 5);
      objective[group + lane] = fit.objective[lane];
    }
  }
}

}  // namespace

void ArapRefinement::update_constant_energy() {
  double deformed = 0.0;
  for (const ConstrainedEdge& edge : constrained_edges_) {
    const Eigen::Vector3d e = row3(positions_, static_cast<std::size_t>(edge.a)) - row3(positions_, static_cast<std::size_t>(edge.b));
    deformed += edge.weight * e.squaredNorm();
  }
  constant_energy_ = scaled_rest_energy_ + deformed;
}

bool ArapRefinement::keep_turns(std::size_t i, const Eigen::Matrix3d& a, const Eigen::Matrix3d& start, RotationFit& fit) const {
  // The fit's rotation relative to the field's, as a swing times a twist about the handle's
  // axis; a twist beyond the limit is clamped to it, the swing kept.
  const Eigen::Vector3d& axis = *turn_axis_;
  const Eigen::Quaterniond field = field_[i];
  Eigen::Quaterniond deviation = field.conjugate() * Eigen::Quaterniond(fit.rotation);
  if (deviation.w() < 0.0) deviation.coeffs() = -deviation.coeffs();
  const double twist = 2.0 * std::atan2(deviation.vec().dot(axis), deviation.w());
  if (std::abs(twist) <= kTurnLimit) return false;
  const Eigen::Quaterniond swing = deviation * Eigen::Quaterniond(Eigen::AngleAxisd(-twist, axis));
  const Eigen::Quaterniond clamped = field * swing * Eigen::Quaterniond(Eigen::AngleAxisd(std::copysign(kTurnLimit, twist), axis));
  const Eigen::Matrix3d rotation = clamped.normalized().toRotationMatrix();
  const double value = (rotation.array() * a.array()).sum();
  const double kept = (start.array() * a.array()).sum();
  // Either is within the limit (every state is); the better one keeps the energy falling.
  fit.rotation = value >= kept ? rotation : start;
  fit.objective = std::max(value, kept);
  return true;
}

double ArapRefinement::fit_rotations(const std::vector<Eigen::Matrix3d>& start_rotations, std::vector<Eigen::Matrix3d>& rotations, int steps) {
  const std::size_t count = static_cast<std::size_t>(rotation_count_);
  const std::size_t chunks = chunk_count(count);
  for_each_chunk(count, [&](std::size_t chunk, std::size_t begin, std::size_t end) {
    double sum = 0.0, unlimited = 0.0, deformed = 0.0;
    // A block's matrices are fitted together, several in SIMD lanes (rotation_newton.h).
    constexpr std::size_t kBlock = 64;
    std::array<Eigen::Matrix3d, kBlock> covariance;
    std::array<double, kBlock> edge_energy, objective;
    std::array<RotationFit, kBlock> fits;
    for (std::size_t first = begin; first < end; first += kBlock) {
      const std::size_t block = std::min(kBlock, end - first);
      if (!turn_axis_) {
        fit_covariances(local_start_.data(), local_vertex_.data(), local_coefficient_.data(), positions_.data(), start_rotations.data(), first,
                        block, kRotationTolerance, steps, rotations.data(), objective.data(), edge_energy.data());
        for (std::size_t k = 0; k < block; ++k) {
          deformed += edge_energy[k];
          unlimited += objective[k];
          sum += objective[k];
        }
        continue;
      }
      // A turn limit looks at each vertex's matrix and fit: they go through memory.
      gather_covariances(local_start_.data(), local_vertex_.data(), local_coefficient_.data(), positions_.data(), first, block, covariance.data(),
                         edge_energy.data());
      for (std::size_t k = 0; k < block; ++k) deformed += edge_energy[k];
      hdeform::fit_rotations(std::span(covariance.data(), block), std::span(start_rotations.data() + first, block), std::span(fits.data(), block),
                             kRotationTolerance, steps);
      for (std::size_t k = 0; k < block; ++k) {
        const std::size_t i = first + k;
        RotationFit& fit = fits[k];
        unlimited += fit.objective;
        keep_turns(i, covariance[k], start_rotations[i], fit);
        rotations[i] = fit.rotation;
        sum += fit.objective;
      }
    }
    partial_[chunk] = sum;
    partial_[chunks + chunk] = unlimited;
    partial_[2 * chunks + chunk] = deformed;
  });
  double fitted = 0.0, fitted_unlimited = 0.0, edges = constant_energy_;
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    fitted += partial_[chunk];
    fitted_unlimited += partial_[chunks + chunk];
    edges += partial_[2 * chunks + chunk];
  }
  unlimited_energy_ = edges - 2.0 * fitted_unlimited;
  return edges - 2.0 * fitted;
}

void ArapRefinement::fit() {
  const auto start = Clock::now();
  const auto from = static_cast<std::size_t>(current_), to = static_cast<std::size_t>(1 - current_);
  const auto refit = [&] { return fit_rotations(rotation_[from], rotation_[to], kIterationSteps); };
  double energy = refit();
  bool fell_back = false;
  if (!consistent_) {
    if (energy > energy_) {
      // The start from the last edit did worse than the paper's result (which energy_ holds): the
      // run goes on from there, as one from the paper's result would (not converged: nothing fell).
      std::copy(paper_.begin(), paper_.end(), positions_.begin());
      std::copy(paper_rotation_.begin(), paper_rotation_.end(), rotation_[to].begin());
      energy = energy_;
      status_.started_from_paper = true;
      fell_back = true;
    }
    consistent_ = true;
  } else if (mixed_ && energy > energy_) {
    // The accelerated step would raise the energy: take the plain one, and start the history anew.
    std::copy(rhs_.begin(), rhs_.end(), positions_.begin());
    energy = refit();
    stored_ = 0;
    oldest_ = 0;
    ++status_.rejected;
  } else if (mixed_) {
    ++status_.accelerated;
  }
  current_ = 1 - current_;
  status_.settled = !fell_back && options_.settle > 0.0 && status_.largest_step <= options_.settle;
  status_.converged = !fell_back && (energy <= energy_floor_ || energy_ - energy <= options_.tolerance * std::abs(energy_) || status_.settled);
  energy_ = energy;
  ++status_.iterations;
  status_.energy = energy_;
  timings_.rotations_ms = milliseconds_since(start);
}

}  // namespace hdeform::detail

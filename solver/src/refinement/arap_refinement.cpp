#include "arap_refinement.h"

#include <Eigen/Cholesky>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>
#include <limits>
#include <span>
#include <utility>

#include "arap_stages.h"
#include "hdeform/rotation_fit.h"
#include "hdeform/stopwatch.h"
#include "lanes.h"
#include "target_clones.h"

namespace hdeform::detail {
namespace {

using Clock = std::chrono::steady_clock;

// The global step's right-hand sides b_i = c_i + Σ_v R_v m_iv of the rows [begin, end), a row per
// vector: R_v's columns (column-major, so three overlapping loads) times m_iv's entries. The pad
// lane stays zero.
HDEFORM_TARGET_CLONES("avx2", "default")
void gather_rotated(const std::size_t* pair_start, const int* pair_vertex, const Eigen::Vector3d* coefficient, const Eigen::Matrix3d* rotations,
                    const double* constant, std::size_t begin, std::size_t end, double* rhs) {
  const Lanes4 zero = {};
  for (std::size_t row = begin; row < end; ++row) {
    Lanes4 b;
    load_lanes(constant + kStride * row, b);
    for (std::size_t p = pair_start[row]; p < pair_start[row + 1]; ++p) {
      const double* ahead = rotations[static_cast<std::size_t>(pair_vertex[p + kPairsAhead])].data();
      __builtin_prefetch(ahead);  // a rotation's 72 bytes span two cache lines at most
      __builtin_prefetch(ahead + 8);
      const double* r = rotations[static_cast<std::size_t>(pair_vertex[p])].data();
      Lanes4 first_two, second_two, last;
      load_lanes(r, first_two);   // R(·,0), R(0,1)
      load_lanes(r + 3, second_two);  // R(·,1), R(0,2)
      load_lanes(r + 5, last);    // R(2,1), R(·,2)
      const Lanes4 column0 = __builtin_shufflevector(first_two, zero, 0, 1, 2, 4);
      const Lanes4 column1 = __builtin_shufflevector(second_two, zero, 0, 1, 2, 4);
      const Lanes4 column2 = __builtin_shufflevector(last, zero, 1, 2, 3, 4);
      const double* m = coefficient[p].data();
      b += (column0 * m[0] + column1 * m[1]) + column2 * m[2];
    }
    store_lanes(b, rhs + kStride * row);
  }
}

// mix()'s pass over the rows [begin, end): f = g − x, the plain step's largest row, the newest
// differences, g and f kept as the previous ones, and with Held columns of history the newest
// column of ΔFᵀΔF and ΔFᵀ f. Held is a template argument so that those sums stay in registers:
// with a count known only at run time GCC kept them in memory, each addition waiting on the store
// before it. Each sum takes its products in the same order either way.
struct DifferencePass {
  const double* g;  // rows of kStride
  const double* x;
  double* previous_g;  // rows of three, as the history
  double* previous_f;
  double* newest_g;  // the newest differences' slot; null while there is no previous step
  double* newest_f;
  std::array<const double*, kMaxRefinementHistory> delta_f;
};
template <int Held>
void difference_rows(const DifferencePass& pass, std::size_t begin, std::size_t end, double* gram, double* along, double& largest) {
  double gram_sum[Held + 1] = {}, along_sum[Held + 1] = {}, largest_square = 0.0;
  for (std::size_t row = begin; row < end; ++row) {
    const double* step_g = pass.g + kStride * row;
    const double* step_x = pass.x + kStride * row;
    const double step[3] = {step_g[0] - step_x[0], step_g[1] - step_x[1], step_g[2] - step_x[2]};
    largest_square = std::max(largest_square, (step[0] * step[0] + step[1] * step[1]) + step[2] * step[2]);
    for (std::size_t c = 0; c < 3; ++c) {
      const std::size_t h = 3 * row + c;
      const double g = step_g[c], f = step[c];
      if (pass.newest_g != nullptr) {
        pass.newest_g[h] = g - pass.previous_g[h];
        pass.newest_f[h] = f - pass.previous_f[h];
      }
      pass.previous_g[h] = g;
      pass.previous_f[h] = f;
      for (int j = 0; j < Held; ++j) {
        const double column = pass.delta_f[static_cast<std::size_t>(j)][h];
        gram_sum[j] += pass.newest_f[h] * column;
        along_sum[j] += column * f;
      }
    }
  }
  for (int j = 0; j < Held; ++j) {
    gram[j] = gram_sum[j];
    along[j] = along_sum[j];
  }
  largest = largest_square;
}
// Calls body.template operator()<H>() with H = count, for a count from 0 to kMaxRefinementHistory.
template <class Body>
void with_history(int count, Body&& body) {
  [&]<int... H>(std::integer_sequence<int, H...>) {
    ((count == H ? body.template operator()<H>() : void()), ...);
  }(std::make_integer_sequence<int, kMaxRefinementHistory + 1>());
}

}  // namespace

ArapRefinement::ArapRefinement(const Mesh& rest, const CotangentWeights& weights, const DirichletSystem& system,
                               std::span<const int> update_triangles, const RefinementOptions& options)
    : system_(system) {
  set_options(options);
  const auto n = static_cast<std::size_t>(rest.vertex_count());
  const auto free_count = static_cast<std::size_t>(system.free_count());
  const auto active = [&](Eigen::Index t) { return weights.kind[static_cast<std::size_t>(t)] != ElementKind::Ignored; };

  // Rotation vertices: the free ones in factor order (compact index = row), then the constrained
  // corners of update triangles; then the remaining corners of the triangles around them.
  std::vector<int> compact(n, -1);
  for (std::size_t row = 0; row < free_count; ++row) {
    compact[static_cast<std::size_t>(system.vertex_of_row()[row])] = static_cast<int>(row);
    vertex_.push_back(system.vertex_of_row()[row]);
  }
  std::vector<bool> carries_rotation(n, false);
  for (const int t : update_triangles) {
    for (int k = 0; k < 3; ++k) carries_rotation[static_cast<std::size_t>(rest.triangles(t, k))] = true;
  }
  for (std::size_t v = 0; v < n; ++v) {
    if (carries_rotation[v] && compact[v] < 0) {
      compact[v] = static_cast<int>(vertex_.size());
      vertex_.push_back(static_cast<int>(v));
    }
  }
  rotation_count_ = static_cast<int>(vertex_.size());

  std::vector<std::size_t> around_start(n + 1, 0);  // every vertex's active triangles
  for (Eigen::Index t = 0; t < rest.triangle_count(); ++t) {
    if (!active(t)) continue;
    for (int k = 0; k < 3; ++k) ++around_start[static_cast<std::size_t>(rest.triangles(t, k)) + 1];
  }
  for (std::size_t v = 0; v < n; ++v) around_start[v + 1] += around_start[v];
  std::vector<int> around(around_start.back());
  {
    std::vector<std::size_t> fill(around_start.begin(), around_start.end() - 1);
    for (Eigen::Index t = 0; t < rest.triangle_count(); ++t) {
      if (!active(t)) continue;
      for (int k = 0; k < 3; ++k) around[fill[static_cast<std::size_t>(rest.triangles(t, k))]++] = static_cast<int>(t);
    }
  }

  // Energy triangles in the order the rotation vertices first reach them.
  std::vector<int> compact_triangle(static_cast<std::size_t>(rest.triangle_count()), -1);
  for (int i = 0; i < rotation_count_; ++i) {
    const auto v = static_cast<std::size_t>(vertex_[static_cast<std::size_t>(i)]);
    for (std::size_t a = around_start[v]; a < around_start[v + 1]; ++a) {
      const int t = around[a];
      if (compact_triangle[static_cast<std::size_t>(t)] >= 0) continue;
      compact_triangle[static_cast<std::size_t>(t)] = static_cast<int>(triangle_.size());
      triangle_.push_back(t);
      for (int k = 0; k < 3; ++k) {
        const auto corner = static_cast<std::size_t>(rest.triangles(t, k));
        if (compact[corner] < 0) {
          compact[corner] = static_cast<int>(vertex_.size());
          vertex_.push_back(static_cast<int>(corner));
        }
      }
    }
  }
  const std::size_t triangles = triangle_.size();
  triangle_corners_.resize(triangles);
  corner_gradient_.resize(triangles);
  rest_edge_energy_.resize(triangles);
  corner_multiplicity_.resize(triangles);
  double rest_scale = 0.0;
  for (std::size_t c = 0; c < triangles; ++c) {
    const int t = triangle_[c];
    std::array<Eigen::Vector3d, 3> p;
    for (int k = 0; k < 3; ++k) {
      const int v = rest.triangles(t, k);
      triangle_corners_[c][static_cast<std::size_t>(k)] = compact[static_cast<std::size_t>(v)];
      p[static_cast<std::size_t>(k)] = rest.positions.row(v).transpose();
    }
    double energy = 0.0, multiplicity = 0.0;
    for (int k = 0; k < 3; ++k) {
      const auto next = static_cast<std::size_t>((k + 1) % 3), previous = static_cast<std::size_t>((k + 2) % 3);
      const auto here = static_cast<std::size_t>(k);
      // As in the Poisson assembly: corner k's edges are opposite corners k+2 and k+1.
      corner_gradient_[c][here] = weights.half_cotangent(t, static_cast<Eigen::Index>(previous)) * (p[here] - p[next]) +
                                  weights.half_cotangent(t, static_cast<Eigen::Index>(next)) * (p[here] - p[previous]);
      energy += weights.half_cotangent(t, k) * (p[next] - p[previous]).squaredNorm();
      if (triangle_corners_[c][here] < rotation_count_) multiplicity += 1.0;
    }
    rest_edge_energy_[c] = energy;
    corner_multiplicity_[c] = multiplicity;
    rest_scale += multiplicity * std::abs(energy);
  }
  energy_floor_ = 1e-14 * rest_scale;
  diagonal_ = bounding_box_diagonal(rest.positions);
  scales_.assign(triangles, std::numeric_limits<double>::quiet_NaN());  // differs from any scale: built at the first edit
  new_scales_.assign(triangles, 1.0);

  // Pairs of each rotation vertex: every corner of its triangles, itself included, ascending.
  local_start_.assign(static_cast<std::size_t>(rotation_count_) + 1, 0);
  incidence_start_.assign(static_cast<std::size_t>(rotation_count_) + 1, 0);
  std::vector<int> neighbours;
  for (int i = 0; i < rotation_count_; ++i) {
    const auto v = static_cast<std::size_t>(vertex_[static_cast<std::size_t>(i)]);
    neighbours.clear();
    for (std::size_t a = around_start[v]; a < around_start[v + 1]; ++a) {
      for (const int corner : triangle_corners_[static_cast<std::size_t>(compact_triangle[static_cast<std::size_t>(around[a])])]) {
        neighbours.push_back(corner);
      }
    }
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
    const std::size_t first = local_vertex_.size();
    local_vertex_.insert(local_vertex_.end(), neighbours.begin(), neighbours.end());
    local_start_[static_cast<std::size_t>(i) + 1] = local_vertex_.size();
    for (std::size_t a = around_start[v]; a < around_start[v + 1]; ++a) {
      Incidence incidence{compact_triangle[static_cast<std::size_t>(around[a])], {}, {}};
      const auto& corners = triangle_corners_[static_cast<std::size_t>(incidence.triangle)];
      for (int k = 0; k < 3; ++k) {
        const auto at = std::lower_bound(neighbours.begin(), neighbours.end(), corners[static_cast<std::size_t>(k)]);
        incidence.slot[static_cast<std::size_t>(k)] = static_cast<int>(first + static_cast<std::size_t>(at - neighbours.begin()));
        if (corners[static_cast<std::size_t>(k)] == i) incidence.corner = k;
      }
      incidence_.push_back(incidence);
    }
    incidence_start_[static_cast<std::size_t>(i) + 1] = incidence_.size();
  }
  // A free vertex's triangles all have a free corner (itself), so all its neighbours carry
  // rotations and its global pairs are its local ones: the first local_start_[free_count] pairs.
  local_coefficient_.assign(local_vertex_.size(), LocalCoefficient{});
  global_coefficient_.assign(local_start_[free_count], Eigen::Vector3d::Zero());
  // The deformed energy Σ_t m_t Σ_e w_e ‖e‖² (m_t: the triangle's rotation corners) edge by edge:
  // each edge of a triangle at the pair of its end with a rotation (the lower of two), or, with
  // neither, in the constant.
  for (int i = 0; i < rotation_count_; ++i) {
    for (std::size_t a = incidence_start_[static_cast<std::size_t>(i)]; a < incidence_start_[static_cast<std::size_t>(i) + 1]; ++a) {
      const Incidence& incidence = incidence_[a];
      const auto c = static_cast<std::size_t>(incidence.triangle);
      for (int k = 0; k < 3; ++k) {  // the edge opposite corner k, if vertex i is one of its ends
        if (k == incidence.corner) continue;
        const int other = 3 - k - incidence.corner;
        const int v = triangle_corners_[c][static_cast<std::size_t>(other)];
        if (v < rotation_count_ && v < i) continue;  // counted at v
        const int t = triangle_[c];
        local_coefficient_[static_cast<std::size_t>(incidence.slot[static_cast<std::size_t>(other)])].values[3] +=
            corner_multiplicity_[c] * weights.half_cotangent(t, k);
      }
    }
  }
  for (std::size_t c = 0; c < triangles; ++c) {
    for (int k = 0; k < 3; ++k) {
      const int a = triangle_corners_[c][static_cast<std::size_t>((k + 1) % 3)], b = triangle_corners_[c][static_cast<std::size_t>((k + 2) % 3)];
      if (a >= rotation_count_ && b >= rotation_count_) {
        constrained_edges_.push_back({a, b, corner_multiplicity_[c] * weights.half_cotangent(triangle_[c], k)});
      }
    }
  }
  local_vertex_.resize(local_vertex_.size() + kPairsAhead, 0);  // the gather's look-ahead (vertex 0: any valid one)

  for (auto& rotations : rotation_) rotations.assign(static_cast<std::size_t>(rotation_count_), Eigen::Matrix3d::Identity());
  paper_rotation_.assign(static_cast<std::size_t>(rotation_count_), Eigen::Matrix3d::Identity());
  paper_.assign(kStride * free_count, 0.0);
  field_.assign(static_cast<std::size_t>(rotation_count_), Eigen::Quaterniond::Identity());
  new_field_.assign(static_cast<std::size_t>(rotation_count_), Eigen::Quaterniond::Identity());
  positions_.assign(kStride * vertex_.size(), 0.0);
  constant_.assign(kStride * free_count, 0.0);
  rhs_.assign(kStride * free_count, 0.0);
  for (auto& column : delta_g_) column.assign(3 * free_count, 0.0);
  for (auto& column : delta_f_) column.assign(3 * free_count, 0.0);
  previous_g_.assign(3 * free_count, 0.0);
  previous_f_.assign(3 * free_count, 0.0);
  const std::size_t most_chunks = std::max({chunk_count(free_count), chunk_count(vertex_.size()), chunk_count(triangles), std::size_t{1}});
  partial_.assign(most_chunks * (2 * kMaxRefinementHistory + 1), 0.0);  // mix(): two sums per column, and the largest step, per chunk
}

void ArapRefinement::set_options(const RefinementOptions& options) {
  options_ = options;
  options_.history = std::clamp(options_.history, 1, kMaxRefinementHistory);
  stored_ = 0;  // a changed window starts afresh
  oldest_ = 0;
}

void ArapRefinement::rebuild_coefficients() {
  const auto free_count = static_cast<int>(system_.free_count());
  tbb::parallel_for(tbb::blocked_range<int>(0, rotation_count_, 512), [&](const tbb::blocked_range<int>& range) {
    for (int i = range.begin(); i != range.end(); ++i) {
      const auto index = static_cast<std::size_t>(i);
      for (std::size_t p = local_start_[index]; p < local_start_[index + 1]; ++p) std::fill_n(local_coefficient_[p].values.begin(), 3, 0.0);
      if (i < free_count) {
        for (std::size_t p = local_start_[index]; p < local_start_[index + 1]; ++p) global_coefficient_[p].setZero();
      }
      for (std::size_t a = incidence_start_[index]; a < incidence_start_[index + 1]; ++a) {
        const Incidence& incidence = incidence_[a];
        const auto t = static_cast<std::size_t>(incidence.triangle);
        const double s = scales_[t];
        const auto& gradient = corner_gradient_[t];
        for (std::size_t k = 0; k < 3; ++k) {
          const auto slot = static_cast<std::size_t>(incidence.slot[k]);
          for (int j = 0; j < 3; ++j) local_coefficient_[slot].values[static_cast<std::size_t>(j)] += s * gradient[k](j);
          if (i < free_count) global_coefficient_[slot] += (s / 3.0) * gradient[static_cast<std::size_t>(incidence.corner)];
        }
      }
    }
  });
  // The rest edges' part of the energy, which only the scales change.
  for_each_chunk(triangle_.size(), [&](std::size_t chunk, std::size_t begin, std::size_t end) {
    double sum = 0.0;
    for (std::size_t c = begin; c < end; ++c) sum += corner_multiplicity_[c] * scales_[c] * scales_[c] * rest_edge_energy_[c];
    partial_[chunk] = sum;
  });
  scaled_rest_energy_ = 0.0;
  for (std::size_t chunk = 0; chunk < chunk_count(triangle_.size()); ++chunk) scaled_rest_energy_ += partial_[chunk];
}

void ArapRefinement::begin(const Eigen::MatrixXd& positions, RefinementStart start) {
  const auto free_count = static_cast<std::size_t>(system_.free_count());
  const bool from_last = start == RefinementStart::FromLastEdit && has_refined_;
  auto& rotations = rotation_[static_cast<std::size_t>(current_)];
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, static_cast<std::size_t>(rotation_count_), 2048), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      // The paper's fit starts from the field's rotation, as a fresh Deformer's does.
      paper_rotation_[i] = new_field_[i].toRotationMatrix();
      // The many small turns of the fits leave rounding in the matrices: a fresh start each edit.
      // (Where the field stays, so do the rotations: the Cayley turns of the fits keep them
      // orthonormal to about 1e-16 per fit, 1e-11 after 100,000.)
      if (from_last && new_field_[i].coeffs() != field_[i].coeffs()) {
        rotations[i] = orthonormalized((new_field_[i] * field_[i].conjugate()).toRotationMatrix() * rotations[i]);
      }
      field_[i] = new_field_[i];
    }
  });
  if (!std::equal(new_scales_.begin(), new_scales_.end(), scales_.begin())) {
    scales_ = new_scales_;
    rebuild_coefficients();
  }
  for (std::size_t c = free_count; c < vertex_.size(); ++c) {
    for (int k = 0; k < 3; ++k) positions_[kStride * c + static_cast<std::size_t>(k)] = positions(vertex_[c], k);
  }
  update_constant_energy();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, free_count, 2048), [&](const auto& range) {
    for (std::size_t row = range.begin(); row != range.end(); ++row) {
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      for (const auto& entry : system_.coupling(static_cast<int>(row))) b.noalias() -= entry.weight * positions.row(entry.vertex).transpose();
      for (int k = 0; k < 3; ++k) constant_[kStride * row + static_cast<std::size_t>(k)] = b(k);
    }
  });

  // The paper's result with rotations fitted to it: where a start from the paper's result
  // begins, and where a start from the last edit goes on if its first iteration does worse.
  for (std::size_t row = 0; row < free_count; ++row) {
    for (int k = 0; k < 3; ++k) paper_[kStride * row + static_cast<std::size_t>(k)] = positions(vertex_[row], k);
  }
  std::copy(paper_.begin(), paper_.end(), positions_.begin());
  status_ = RefinementStatus{};
  energy_ = fit_rotations(paper_rotation_, paper_rotation_, kPaperFitSteps);
  status_.unrefined_energy = unlimited_energy_;  // the plain ARAP energy of the paper's result
  status_.energy = energy_;
  status_.converged = energy_ <= energy_floor_;  // nothing moved: nothing to refine, the result stays as it is
  consistent_ = !from_last;
  if (!from_last) std::copy(paper_rotation_.begin(), paper_rotation_.end(), rotations.begin());
  has_refined_ = true;
  stored_ = 0;
  oldest_ = 0;
  has_previous_ = false;
}

void ArapRefinement::begin_at_rest() {
  status_ = RefinementStatus{};
  status_.converged = true;
  energy_ = 0.0;
}

void ArapRefinement::assemble() {
  const auto start = Clock::now();
  const auto& matrices = rotation_[static_cast<std::size_t>(current_)];
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, static_cast<std::size_t>(system_.free_count()), 1024), [&](const auto& range) {
    gather_rotated(local_start_.data(), local_vertex_.data(), global_coefficient_.data(), matrices.data(), constant_.data(), range.begin(),
                   range.end(), rhs_.data());
  });
  timings_.rhs_ms = milliseconds_since(start);
}

void ArapRefinement::solve() {
  const auto start = Clock::now();
  if (!rhs_.empty()) system_.factor().solve_block(rhs_.data(), 3, static_cast<int>(kStride));
  timings_.solve_ms = milliseconds_since(start);
}

void ArapRefinement::mix() {
  const auto start = Clock::now();
  const std::size_t rows = rhs_.size() / kStride;
  double* x = positions_.data();  // the free rows come first: the current state
  const double* g = rhs_.data();
  mixed_ = false;
  if (!consistent_) {
    // A warm start has rotations but no positions they were fitted to: no residual yet, and no
    // step G(x) − x from x.
    status_.largest_step = std::numeric_limits<double>::infinity();
    std::copy(rhs_.begin(), rhs_.end(), positions_.begin());
    has_previous_ = false;
    timings_.acceleration_ms = milliseconds_since(start);
    return;
  }
  const int history = options_.history;
  int slot = -1;
  if (has_previous_) {
    if (stored_ < history) {
      slot = (oldest_ + stored_) % history;
      ++stored_;
    } else {
      slot = oldest_;
      oldest_ = (oldest_ + 1) % history;
    }
  }
  // One pass over the rows (difference_rows): the plain step's largest row (for the settle test),
  // the newest differences and, to accelerate, the Gram matrix's newest column, as fixed-order
  // sums of chunk sums.
  const bool accelerate = options_.accelerate && stored_ > 0;
  const int stride = 2 * history + 1;
  const int held = stored_;
  // x and g have rows of four (the pads stay zero: only the first three values of a row are read
  // and written); the history, which no solve reads, has rows of three: a quarter less memory
  // (no faster: measured).
  DifferencePass pass{g, x, previous_g_.data(), previous_f_.data(), nullptr, nullptr, {}};
  if (slot >= 0) {
    pass.newest_g = delta_g_[static_cast<std::size_t>(slot)].data();
    pass.newest_f = delta_f_[static_cast<std::size_t>(slot)].data();
  }
  for (int j = 0; j < held; ++j) pass.delta_f[static_cast<std::size_t>(j)] = delta_f_[static_cast<std::size_t>(j)].data();
  for_each_chunk(rows, [&](std::size_t chunk, std::size_t begin, std::size_t end) {
    double* sums = partial_.data() + chunk * static_cast<std::size_t>(stride);
    with_history(accelerate ? held : 0, [&]<int Held>() { difference_rows<Held>(pass, begin, end, sums, sums + history, sums[2 * history]); });
  });
  has_previous_ = true;
  const std::size_t chunks = chunk_count(rows);
  double largest_square = 0.0;
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    largest_square = std::max(largest_square, partial_[chunk * static_cast<std::size_t>(stride) + 2 * static_cast<std::size_t>(history)]);
  }
  status_.largest_step = diagonal_ > 0.0 ? std::sqrt(largest_square) / diagonal_ : std::numeric_limits<double>::infinity();
  if (!accelerate) {
    std::copy(rhs_.begin(), rhs_.end(), positions_.begin());
    timings_.acceleration_ms = milliseconds_since(start);
    return;
  }
  Eigen::Matrix<double, kMaxRefinementHistory, 1> projection = Eigen::Matrix<double, kMaxRefinementHistory, 1>::Zero();
  for (int j = 0; j < stored_; ++j) {
    double gram = 0.0, along = 0.0;
    for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
      gram += partial_[chunk * static_cast<std::size_t>(stride) + static_cast<std::size_t>(j)];
      along += partial_[chunk * static_cast<std::size_t>(stride) + static_cast<std::size_t>(history + j)];
    }
    gram_(slot, j) = gram_(j, slot) = gram;
    projection(j) = along;
  }
  // The columns held are the slots 0..stored_-1 (the ring fills from 0, then wraps); the unused
  // rest of the fixed-size system is the identity, so their coefficients come out zero.
  const int m = stored_;
  using Small = Eigen::Matrix<double, kMaxRefinementHistory, kMaxRefinementHistory>;
  Small normal = Small::Identity();
  normal.topLeftCorner(m, m) = gram_.topLeftCorner(m, m);
  // A relative ridge keeps nearly dependent differences from producing huge coefficients.
  double largest = 0.0;
  for (int j = 0; j < m; ++j) largest = std::max(largest, normal(j, j));
  for (int j = 0; j < m; ++j) normal(j, j) += 1e-10 * largest + std::numeric_limits<double>::min();
  const Eigen::LDLT<Small> ldlt(normal);
  const Eigen::Matrix<double, kMaxRefinementHistory, 1> theta = ldlt.solve(projection);
  if (ldlt.info() != Eigen::Success || !theta.allFinite()) {
    stored_ = 0;
    oldest_ = 0;
    std::copy(rhs_.begin(), rhs_.end(), positions_.begin());
    timings_.acceleration_ms = milliseconds_since(start);
    return;
  }
  for_each_chunk(rows, [&](std::size_t, std::size_t begin, std::size_t end) {
    with_history(m, [&]<int Held>() {
      for (std::size_t row = begin; row < end; ++row) {
        for (std::size_t c = 0; c < 3; ++c) {
          const std::size_t k = kStride * row + c, h = 3 * row + c;
          double value = g[k];
          for (int j = 0; j < Held; ++j) value -= theta(j) * delta_g_[static_cast<std::size_t>(j)][h];
          x[k] = value;
        }
      }
    });
  });
  mixed_ = true;
  timings_.acceleration_ms = milliseconds_since(start);
}

void ArapRefinement::write(Eigen::MatrixXd& positions) const {
  const auto free_count = static_cast<std::size_t>(system_.free_count());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, free_count, 4096), [&](const auto& range) {
    for (std::size_t row = range.begin(); row != range.end(); ++row) {
      for (int k = 0; k < 3; ++k) positions(vertex_[row], k) = positions_[kStride * row + static_cast<std::size_t>(k)];
    }
  });
}

}  // namespace hdeform::detail

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

#include "hdeform/rotation_fit.h"
#include "hdeform/stopwatch.h"
#include "lanes.h"
#include "rotation_newton.h"
#include "target_clones.h"

namespace hdeform::detail {
namespace {

using Clock = std::chrono::steady_clock;

// Work is cut into chunks of this many items, the same for any number of threads; a sum is the
// sum of its chunks' partial sums in chunk order.
constexpr std::size_t kChunk = 2048;
std::size_t chunk_count(std::size_t items) { return (items + kChunk - 1) / kChunk; }

template <class Body>
void for_each_chunk(std::size_t items, Body body) {
  tbb::parallel_for(std::size_t{0}, chunk_count(items), [&](std::size_t chunk) {
    body(chunk, chunk * kChunk, std::min(items, (chunk + 1) * kChunk));
  });
}

// Rotation fits: Newton steps from the last fit, which moves little. For the paper's result, whose
// energy is reported and decides where an edit starts: up to eight from the field's rotations.
// Within an iteration one: each step raises the fit, so the energy still falls, and the rotations
// converge with the positions (one step or two per iteration take as many iterations to converge:
// buddha-206k, cylinder).
constexpr double kRotationTolerance = 1e-7;
constexpr int kPaperFitSteps = 8;
constexpr int kIterationSteps = 1;

// The per-vertex arrays (positions, right-hand sides, the acceleration's differences) keep x, y, z
// and a zero pad per row: the layout in which the solve sums a row's three values as one vector.
constexpr std::size_t kStride = SparseCholesky::fast_solve_stride(3);

Eigen::Vector3d row3(const std::vector<double>& values, std::size_t row) {
  return {values[kStride * row], values[kStride * row + 1], values[kStride * row + 2]};
}

static_assert(kStride == 4, "the gathers below load a row of positions as four lanes");

// The two gathers below read, for each pair, its neighbour's row (a position, a rotation), scattered
// over the mesh, and waited for it: they ask for it this many pairs early (the right-hand side's
// stage 1.14-1.16 -> 0.85-0.90 ms at 48 on the Buddha; 0.90-0.97 at 32, 0.81-0.99 at 64). The pair
// list carries this many padding entries so the look-ahead stays inside it.
constexpr std::size_t kPairsAhead = 48;

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
// differs (through memory, the matrices' copies in and out of the lanes took about a third of the
// fits' time). objective and edge_energy are indexed from first.
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
      gather_covariances(local_start_.data(), local_vertex_.data(), local_coefficient_.data(), positions_.data(), first, block, covariance.data(),
                         edge_energy.data());
      for (std::size_t k = 0; k < block; ++k) deformed += edge_energy[k];
      hdeform::fit_rotations(std::span(covariance.data(), block), std::span(start_rotations.data() + first, block), std::span(fits.data(), block),
                             kRotationTolerance, steps);
      for (std::size_t k = 0; k < block; ++k) {
        const std::size_t i = first + k;
        RotationFit& fit = fits[k];
        unlimited += fit.objective;
        if (turn_axis_) keep_turns(i, covariance[k], start_rotations[i], fit);
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
  timings_.rotations_ms = milliseconds_since(start);
}

void ArapRefinement::finish(Eigen::MatrixXd& positions) {
  const auto free_count = static_cast<std::size_t>(system_.free_count());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, free_count, 4096), [&](const auto& range) {
    for (std::size_t row = range.begin(); row != range.end(); ++row) {
      for (int k = 0; k < 3; ++k) positions(vertex_[row], k) = positions_[kStride * row + static_cast<std::size_t>(k)];
    }
  });
  ++status_.iterations;
  status_.energy = energy_;
}

}  // namespace hdeform::detail

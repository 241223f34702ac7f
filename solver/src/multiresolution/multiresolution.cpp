#include "hdeform/multiresolution.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <span>
#include <utility>

#include "hdeform/errors.h"
#include "hdeform/trace.h"
#include "lanes.h"
#include "target_clones.h"

namespace hdeform {
namespace {

using detail::Lanes4;

constexpr std::size_t kVertexGrain = 2048;
// A whole rebuild's triangles per task, and how far ahead it asks for their corners.
constexpr Eigen::Index kTriangleGrain = 512, kCornersAhead = 16;

// The closest point of triangle (a, b, c) to p as barycentric weights of b and c (Ericson,
// Real-Time Collision Detection, §5.1.5).
Eigen::Vector2d closest_point_weights(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                      const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {0, 0};
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return {d1 / (d1 - d3), 0};
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return {0, d2 / (d2 - d6)};
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {1 - w, w};
  }
  const double denominator = 1.0 / (va + vb + vc);
  return {vb * denominator, vc * denominator};
}

// A point or a vector as x, y, z and a zero in lanes: the rebuild turns a vertex's detail and
// adds its foot as a few vector operations (the rebuild took about a fifth less time). Each lane
// is one coordinate's plain double arithmetic, so the baseline build and the AVX2 clone (no FMA)
// give the same bits.
[[gnu::always_inline]] inline void to_lanes(const Eigen::Vector3d& v, Lanes4& lanes) { lanes = Lanes4{v.x(), v.y(), v.z(), 0.0}; }
[[gnu::always_inline]] inline Eigen::Vector3d from_lanes(const Lanes4& lanes) { return {lanes[0], lanes[1], lanes[2]}; }
[[gnu::always_inline]] inline double squared_length(const Lanes4& v) { return (v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]; }
[[gnu::always_inline]] inline void cross(const Lanes4& u, const Lanes4& v, Lanes4& result) {
  const Lanes4 u_yzx = __builtin_shufflevector(u, u, 1, 2, 0, 3), u_zxy = __builtin_shufflevector(u, u, 2, 0, 1, 3);
  const Lanes4 v_yzx = __builtin_shufflevector(v, v, 1, 2, 0, 3), v_zxy = __builtin_shufflevector(v, v, 2, 0, 1, 3);
  result = u_yzx * v_zxy - u_zxy * v_yzx;
}

// What a fine vertex's position takes from its base triangle (a, b, c): the corner a, the edges
// to b and c, and the frame, whose columns are the first edge e = b − a over its length, the
// normal n = e × (c − a) over its length, and the second over the first (a degenerate
// triangle's zero column stays zero). A whole rebuild makes the map once per base triangle, so
// that each of the five or so fine vertices on a triangle costs only a weighted sum: the frame's
// square roots, divisions and cross products per vertex were most of a rebuild's time.
struct FootMap {
  Lanes4 origin, to_b, to_c;
  std::array<Lanes4, 3> frame;
};
[[gnu::always_inline]] inline void make_foot_map(const Lanes4& a, const Lanes4& b, const Lanes4& c, FootMap& map) {
  map.origin = a;
  map.to_b = b - a;
  map.to_c = c - a;
  Lanes4 normal;
  cross(map.to_b, map.to_c, normal);
  const double edge_length = std::sqrt(squared_length(map.to_b)), normal_length = std::sqrt(squared_length(normal));
  map.frame[0] = map.to_b * (edge_length > 0.0 ? 1.0 / edge_length : 0.0);
  map.frame[2] = normal * (normal_length > 0.0 ? 1.0 / normal_length : 0.0);
  cross(map.frame[2], map.frame[0], map.frame[1]);
}
Eigen::Matrix3d frame_matrix(const FootMap& map) {
  Eigen::Matrix3d frame;
  for (int k = 0; k < 3; ++k) frame.col(k) = from_lanes(map.frame[static_cast<std::size_t>(k)]);
  return frame;
}

// A fine vertex with weights wb, wc of b and c and its detail. One function for encoding, the
// rest reconstruction and every later one: the same arithmetic, so the rest base reproduces its
// own reconstruction bit for bit.
[[gnu::always_inline]] inline void reconstruct_in_lanes(const FootMap& map, double wb, double wc, const double* detail, Lanes4& position) {
  const Lanes4 foot = (map.origin + wb * map.to_b) + wc * map.to_c;
  position = foot + ((map.frame[0] * detail[0] + map.frame[1] * detail[1]) + map.frame[2] * detail[2]);
}

// A fine row's position on its foot triangle: the reconstruction plus the row's correction. False
// where the correction is NaN (an inexact rest, placed from inexact_rest_): `position` then holds
// the reconstruction alone.
template <class Row>
[[gnu::always_inline]] inline bool corrected_position(const FootMap& map, const Row& row, Lanes4& position) {
  reconstruct_in_lanes(map, row.wb, row.wc, row.detail.data(), position);
  if (std::isnan(row.correction[0])) return false;
  const Lanes4 correction = {row.correction[0], row.correction[1], row.correction[2], 0.0f};
  position += correction;
  return true;
}

// Base triangle t's map from the base's (deformed) positions.
[[gnu::always_inline]] inline void base_triangle_map(const Eigen::MatrixXd& base_positions, const Eigen::MatrixXi& triangles, Eigen::Index t,
                                                     FootMap& map) {
  const auto corner = [&](int k, Lanes4& lanes) {  // (vectors by reference: see lanes.h)
    const Eigen::Index v = triangles(t, k);
    lanes = Lanes4{base_positions(v, 0), base_positions(v, 1), base_positions(v, 2), 0.0};
  };
  Lanes4 a, b, c;
  corner(0, a);
  corner(1, b);
  corner(2, c);
  make_foot_map(a, b, c, map);
}

// The rebuild of the fine vertices on the base triangles [first, last): the triangles' maps, and
// each row's position where its vertex is. A row whose correction is NaN (an inexact rest) is
// left to the caller.
template <class Row>
HDEFORM_TARGET_CLONES("avx2", "default")
void rebuild_by_triangle(Eigen::Index first, Eigen::Index last, const Eigen::MatrixXi& triangles, const int* triangle_rows, const Row* rows,
                         const char* skip, const Eigen::MatrixXd& base_positions, std::array<double*, 3> column) {
  for (Eigen::Index t = first; t != last; ++t) {
    // The corners of the triangles to come are scattered over the base: asked for early.
    if (t + kCornersAhead < last) {
      for (int k = 0; k < 3; ++k) {
        const int u = triangles(t + kCornersAhead, k);
        for (int axis = 0; axis < 3; ++axis) __builtin_prefetch(&base_positions(u, axis));
      }
    }
    const int begin = triangle_rows[t], end = triangle_rows[t + 1];
    if (begin == end || (skip != nullptr && skip[t] != 0)) continue;
    FootMap map;
    base_triangle_map(base_positions, triangles, t, map);
    for (int i = begin; i != end; ++i) {
      const Row& row = rows[i];
      Lanes4 position;
      if (!corrected_position(map, row, position)) continue;
      for (int axis = 0; axis < 3; ++axis) column[static_cast<std::size_t>(axis)][row.vertex] = position[axis];
    }
  }
}

// Vertex → triangles, compressed rows.
struct Incidence {
  std::vector<int> start;
  std::vector<int> triangle;
  std::span<const int> of(int v) const {
    const auto i = static_cast<std::size_t>(v);
    return {triangle.data() + start[i], static_cast<std::size_t>(start[i + 1] - start[i])};
  }
};
Incidence incidence(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count) {
  Incidence result;
  result.start.assign(static_cast<std::size_t>(vertex_count) + 1, 0);
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    for (int k = 0; k < 3; ++k) ++result.start[static_cast<std::size_t>(triangles(t, k)) + 1];
  }
  for (std::size_t v = 0; v + 1 < result.start.size(); ++v) result.start[v + 1] += result.start[v];
  result.triangle.resize(static_cast<std::size_t>(result.start.back()));
  std::vector<int> next(result.start.begin(), result.start.end() - 1);
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    for (int k = 0; k < 3; ++k) result.triangle[static_cast<std::size_t>(next[static_cast<std::size_t>(triangles(t, k))]++)] = static_cast<int>(t);
  }
  return result;
}

// For every fine vertex the base vertex fewest fine edges away (a breadth-first search from
// every base vertex at once, in index order, so ties go the same way every time); −1 where none
// is reachable. Along the surface, so a thin part never takes the other side's base vertex.
std::vector<int> nearest_base_along_surface(const Mesh& fine, const std::vector<int>& base_of_fine, const Incidence& fine_incidence) {
  const auto n = static_cast<std::size_t>(fine.vertex_count());
  std::vector<int> nearest(n, -1);
  std::vector<int> queue;
  queue.reserve(n);
  for (std::size_t v = 0; v < n; ++v) {
    if (base_of_fine[v] >= 0) {
      nearest[v] = base_of_fine[v];
      queue.push_back(static_cast<int>(v));
    }
  }
  // The queue's vertices lie all over the mesh: their triangle lists, and further ahead their
  // lists' places, are asked for early.
  constexpr std::size_t kListsAhead = 8, kPlacesAhead = 16;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    if (head + kPlacesAhead < queue.size()) __builtin_prefetch(&fine_incidence.start[static_cast<std::size_t>(queue[head + kPlacesAhead])]);
    if (head + kListsAhead < queue.size()) {
      for (const int t : fine_incidence.of(queue[head + kListsAhead])) {
        for (int k = 0; k < 3; ++k) __builtin_prefetch(&fine.triangles(t, k));
      }
    }
    const int v = queue[head];
    for (const int t : fine_incidence.of(v)) {
      for (int k = 0; k < 3; ++k) {
        const int w = fine.triangles(t, k);
        if (nearest[static_cast<std::size_t>(w)] >= 0) continue;
        nearest[static_cast<std::size_t>(w)] = nearest[static_cast<std::size_t>(v)];
        queue.push_back(w);
      }
    }
  }
  return nearest;
}

}  // namespace

DetailEncoding::DetailEncoding(const Mesh& fine, const BaseMesh& base)
    : base_count_(base.mesh.vertex_count()), base_triangles_(base.mesh.triangles) {
  const trace::Scope traced("detail encoding", "set-up");
  const auto n = static_cast<std::size_t>(fine.vertex_count());
  base_of_fine_.assign(n, -1);
  for (std::size_t j = 0; j < base.fine_vertex.size(); ++j) base_of_fine_[static_cast<std::size_t>(base.fine_vertex[j])] = static_cast<int>(j);
  std::optional<trace::Scope> step(std::in_place, "encoding: incidence", "set-up");
  const Incidence fine_incidence = incidence(fine.triangles, fine.vertex_count());
  const Incidence base_incidence = incidence(base.mesh.triangles, base.mesh.vertex_count());
  step.emplace("encoding: nearest base vertex", "set-up");
  const std::vector<int> nearest = nearest_base_along_surface(fine, base_of_fine_, fine_incidence);
  step.emplace("encoding: feet and details", "set-up");

  foot_triangle_.assign(n, -1);
  Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> barycentric = Eigen::MatrixX2d::Zero(fine.vertex_count(), 2);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> detail = Eigen::MatrixX3d::Zero(fine.vertex_count(), 3);
  // Until every foot is known: the reconstruction's own arithmetic on the rest base.
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> rest_reconstruction = fine.positions;
  const auto& base_positions = base.mesh.positions;
  auto corner = [&](int t, int k) -> Eigen::Vector3d { return base_positions.row(base_triangles_(t, k)).transpose(); };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kVertexGrain), [&](const auto& range) {
    std::vector<int> candidates;
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      const int vertex = static_cast<int>(v);
      if (base_of_fine_[v] >= 0) {
        // Its own base vertex as corner 0 of an incident triangle: the foot is the vertex itself.
        const int j = base_of_fine_[v];
        const auto around = base_incidence.of(j);
        if (around.empty()) continue;
        const int t = around.front();
        const int k = base_triangles_(t, 0) == j ? 0 : base_triangles_(t, 1) == j ? 1 : 2;
        foot_triangle_[v] = t;
        // The weights that pick corner k alone.
        barycentric.row(vertex) << (k == 1 ? 1.0 : 0.0), (k == 2 ? 1.0 : 0.0);
        continue;
      }
      if (nearest[v] < 0) continue;
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      for (const int t : fine_incidence.of(vertex)) {
        const Eigen::Vector3d a = fine.positions.row(fine.triangles(t, 0));
        normal += (Eigen::Vector3d(fine.positions.row(fine.triangles(t, 1))) - a).cross(Eigen::Vector3d(fine.positions.row(fine.triangles(t, 2))) - a);
      }
      const Eigen::Vector3d p = fine.positions.row(vertex).transpose();
      // Best: facing the fine surface's way first, then nearest.
      int best = -1;
      bool best_faces = false;
      double best_distance = std::numeric_limits<double>::infinity();
      Eigen::Vector2d best_weights = Eigen::Vector2d::Zero();
      auto search = [&](std::span<const int> triangles) {
        for (const int t : triangles) {
          const Eigen::Vector3d a = corner(t, 0), b = corner(t, 1), c = corner(t, 2);
          const Eigen::Vector3d area = (b - a).cross(c - a);
          if (!(area.squaredNorm() > 0.0)) continue;  // degenerate: no frame
          const Eigen::Vector2d w = closest_point_weights(p, a, b, c);
          const double distance = (a + w[0] * (b - a) + w[1] * (c - a) - p).squaredNorm();
          const bool faces = area.dot(normal) > 0.0;
          if ((faces && !best_faces) || (faces == best_faces && distance < best_distance)) {
            best = t;
            best_faces = faces;
            best_distance = distance;
            best_weights = w;
          }
        }
      };
      // The triangles around the nearest base vertex; when the closest point lies on the far
      // edge of that fan, the triangles around the best one's corners too.
      const int centre = nearest[v];
      search(base_incidence.of(centre));
      if (best >= 0) {
        const int k = base_triangles_(best, 0) == centre ? 0 : base_triangles_(best, 1) == centre ? 1 : 2;
        const double centre_weight = k == 0 ? 1.0 - best_weights[0] - best_weights[1] : best_weights[k - 1];
        if (!(centre_weight > 0.0)) {
          // Not the centre's own triangles again: none of them can beat the best of them.
          candidates.clear();
          for (int corner_index = 0; corner_index < 3; ++corner_index) {
            if (corner_index == k) continue;
            for (const int u : base_incidence.of(base_triangles_(best, corner_index))) {
              if (base_triangles_(u, 0) != centre && base_triangles_(u, 1) != centre && base_triangles_(u, 2) != centre) candidates.push_back(u);
            }
          }
          std::sort(candidates.begin(), candidates.end());
          candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
          search(candidates);
        }
      }
      if (best < 0) continue;
      const Eigen::Vector3d a = corner(best, 0), b = corner(best, 1), c = corner(best, 2);
      foot_triangle_[v] = best;
      barycentric.row(vertex) = best_weights.transpose();
      Lanes4 a_lanes, b_lanes, c_lanes;
      to_lanes(a, a_lanes);
      to_lanes(b, b_lanes);
      to_lanes(c, c_lanes);
      FootMap map;
      make_foot_map(a_lanes, b_lanes, c_lanes, map);
      const Eigen::Vector3d foot = from_lanes((map.origin + best_weights[0] * map.to_b) + best_weights[1] * map.to_c);
      const Eigen::Vector3d own_detail = frame_matrix(map).transpose() * (p - foot);
      detail.row(vertex) = own_detail.transpose();
      Lanes4 reconstruction;
      reconstruct_in_lanes(map, best_weights[0], best_weights[1], own_detail.data(), reconstruction);
      rest_reconstruction.row(vertex) = from_lanes(reconstruction).transpose();
    }
  });
  step.emplace("encoding: rows by foot triangle", "set-up");
  for (std::size_t v = 0; v < n; ++v) largest_detail_ = std::max(largest_detail_, detail.row(static_cast<Eigen::Index>(v)).norm());

  // The encoding's own triangle order: by last use in fine vertex order (base vertices aside), so
  // that a rebuild, which goes triangle by triangle, writes nearby fine vertices one after another
  // rather than all over (the base's order follows its collapses, not the fine mesh). By last use,
  // not first: a triangle's fine vertices come from every level of a subdivision, most from the
  // finest and last numbered, and the writes follow those (on the 3.3M Buddha the rebuild is about
  // a fifth shorter than by first use). Only foot_corners() shows a triangle, by corners.
  std::vector<int> last_use(static_cast<std::size_t>(base_triangles_.rows()), -1);
  for (std::size_t v = 0; v < n; ++v) {
    if (base_of_fine_[v] < 0 && foot_triangle_[v] >= 0) last_use[static_cast<std::size_t>(foot_triangle_[v])] = static_cast<int>(v);
  }
  std::vector<int> renumbered(static_cast<std::size_t>(base_triangles_.rows()), -1);
  int next = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const int t = foot_triangle_[v];
    if (base_of_fine_[v] < 0 && t >= 0 && last_use[static_cast<std::size_t>(t)] == static_cast<int>(v)) renumbered[static_cast<std::size_t>(t)] = next++;
  }
  for (int& t : foot_triangle_) {
    if (t < 0) continue;
    int& number = renumbered[static_cast<std::size_t>(t)];
    if (number < 0) number = next++;
    t = number;
  }
  Eigen::MatrixXi ordered(base_triangles_.rows(), 3);
  for (Eigen::Index t = 0; t < base_triangles_.rows(); ++t) {
    int& number = renumbered[static_cast<std::size_t>(t)];
    if (number < 0) number = next++;
    ordered.row(number) = base_triangles_.row(t);
  }
  base_triangles_ = std::move(ordered);

  // The rebuild adds rest − rest reconstruction to its own reconstruction: on the rest base that
  // is the rest position to the last bit wherever the difference is exact (Sterbenz: the two agree
  // to rounding, so it is a few ulps, which a float holds too), which is checked here. Where a
  // coordinate is near zero it may round; such a vertex keeps both and is rebuilt as
  // rest + (now − rest reconstruction).
  fine_of_base_ = base.fine_vertex;
  row_of_fine_.assign(n, -1);
  const auto triangle_count = static_cast<std::size_t>(base_triangles_.rows());
  triangle_rows_.assign(triangle_count + 1, 0);
  std::size_t unreferenced = 0;
  for (std::size_t v = 0; v < n; ++v) {
    if (base_of_fine_[v] >= 0) continue;
    if (foot_triangle_[v] < 0) ++unreferenced;
    else ++triangle_rows_[static_cast<std::size_t>(foot_triangle_[v]) + 1];
  }
  std::partial_sum(triangle_rows_.begin(), triangle_rows_.end(), triangle_rows_.begin());
  std::vector<int> next_row(triangle_rows_.begin(), triangle_rows_.end() - 1);
  int next_unreferenced = triangle_rows_.back();
  for (std::size_t v = 0; v < n; ++v) {
    if (base_of_fine_[v] >= 0) continue;
    const int t = foot_triangle_[v];
    row_of_fine_[v] = t < 0 ? next_unreferenced++ : next_row[static_cast<std::size_t>(t)]++;
  }
  rows_.resize(static_cast<std::size_t>(triangle_rows_.back()) + unreferenced);
  std::vector<char> inexact(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kVertexGrain), [&](const auto& range) {
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      if (base_of_fine_[v] >= 0) continue;
      const auto row = static_cast<Eigen::Index>(v);
      FineRow& entry = rows_[static_cast<std::size_t>(row_of_fine_[v])];
      entry.vertex = static_cast<int>(v);
      if (foot_triangle_[v] < 0) {
        for (int axis = 0; axis < 3; ++axis) entry.detail[static_cast<std::size_t>(axis)] = fine.positions(row, axis);
        continue;
      }
      entry.wb = barycentric(row, 0);
      entry.wc = barycentric(row, 1);
      bool exact = true;
      for (int axis = 0; axis < 3; ++axis) {
        const auto a = static_cast<std::size_t>(axis);
        entry.detail[a] = detail(row, axis);
        const double difference = fine.positions(row, axis) - rest_reconstruction(row, axis);
        entry.correction[a] = static_cast<float>(difference);
        exact = exact && static_cast<double>(entry.correction[a]) == difference && rest_reconstruction(row, axis) + difference == fine.positions(row, axis);
      }
      if (!exact) {
        entry.correction.fill(std::numeric_limits<float>::quiet_NaN());
        inexact[v] = 1;
      }
    }
  });
  for (std::size_t v = 0; v < n; ++v) {
    if (inexact[v] != 0) {
      const auto row = static_cast<Eigen::Index>(v);
      inexact_rest_.push_back({static_cast<int>(v), fine.positions.row(row).transpose(), rest_reconstruction.row(row).transpose()});
    }
  }
}

void DetailEncoding::check_base(const Eigen::MatrixXd& base_positions) const {
  if (base_positions.rows() != base_count_ || base_positions.cols() != 3) {
    throw std::invalid_argument("DetailEncoding::reconstruct: the base positions are " + std::to_string(base_positions.rows()) + "×" +
                                std::to_string(base_positions.cols()) + " for a base of " + std::to_string(base_count_) + " vertices");
  }
}

// A fine vertex's position from its row and its foot triangle, as the whole rebuild makes it (the
// same lanes), also where the rest was inexact; for the rebuild of some vertices.
Eigen::Vector3d DetailEncoding::position_of(const FineRow& row, Eigen::Index triangle, const Eigen::MatrixXd& base_positions) const {
  FootMap map;
  base_triangle_map(base_positions, base_triangles_, triangle, map);
  Lanes4 position;
  if (corrected_position(map, row, position)) return from_lanes(position);
  const auto inexact = std::lower_bound(inexact_rest_.begin(), inexact_rest_.end(), row.vertex,
                                        [](const InexactRest& entry, int vertex) { return entry.vertex < vertex; });
  return inexact->rest + (from_lanes(position) - inexact->rest_reconstruction);
}

void DetailEncoding::reconstruct(const Eigen::MatrixXd& base_positions, Eigen::MatrixXd& fine_positions) const {
  rebuild(base_positions, fine_positions, nullptr);
}

std::vector<char> DetailEncoding::triangles_only_of(std::span<const int> vertices) const {
  std::vector<char> among(static_cast<std::size_t>(fine_count()), 0);
  for (const int v : vertices) {
    if (v < 0 || v >= fine_count()) {
      throw std::invalid_argument("DetailEncoding::triangles_only_of: vertex " + std::to_string(v) + " is not in the fine mesh");
    }
    among[static_cast<std::size_t>(v)] = 1;
  }
  const auto triangles = static_cast<std::size_t>(base_triangles_.rows());
  std::vector<char> only(triangles, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles, kTriangleGrain), [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const auto first = rows_.begin() + triangle_rows_[t], last = rows_.begin() + triangle_rows_[t + 1];
      only[t] = first != last && std::all_of(first, last, [&](const FineRow& row) { return among[static_cast<std::size_t>(row.vertex)] != 0; });
    }
  });
  return only;
}

void DetailEncoding::reconstruct(const Eigen::MatrixXd& base_positions, Eigen::MatrixXd& fine_positions, const std::vector<char>& skip) const {
  if (skip.size() != static_cast<std::size_t>(base_triangles_.rows())) {
    throw std::invalid_argument("DetailEncoding::reconstruct: " + std::to_string(skip.size()) + " triangles marked for " +
                                std::to_string(base_triangles_.rows()) + " foot triangles");
  }
  if (fine_positions.rows() != fine_count() || fine_positions.cols() != 3) {
    throw std::invalid_argument("DetailEncoding::reconstruct: a rebuild that skips vertices needs the fine positions (" + std::to_string(fine_count()) +
                                "×3) to keep them");
  }
  rebuild(base_positions, fine_positions, skip.data());
}

void DetailEncoding::rebuild(const Eigen::MatrixXd& base_positions, Eigen::MatrixXd& fine_positions, const char* skip) const {
  check_base(base_positions);
  fine_positions.resize(fine_count(), 3);
  const trace::Scope traced("fine mesh from the base", "update");
  const std::array<double*, 3> column{fine_positions.col(0).data(), fine_positions.col(1).data(), fine_positions.col(2).data()};
  auto store = [&](int vertex, const Eigen::Vector3d& position) {
    for (int axis = 0; axis < 3; ++axis) column[static_cast<std::size_t>(axis)][vertex] = position[axis];
  };
  // Triangle by triangle: its map made once, in registers, for the five or so fine vertices on it
  // (a table of maps written and read back cost a fifth of the rebuild). The vertices' own rows
  // come in sequence; their positions go where the vertices are.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, base_triangles_.rows(), kTriangleGrain), [&](const auto& range) {
    rebuild_by_triangle(range.begin(), range.end(), base_triangles_, triangle_rows_.data(), rows_.data(), skip, base_positions, column);
  });
  // None on the 3.3M Buddha; a mesh with many coordinates near zero may have more: in parallel.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, inexact_rest_.size(), kVertexGrain), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const auto v = static_cast<std::size_t>(inexact_rest_[i].vertex);
      store(inexact_rest_[i].vertex, position_of(rows_[static_cast<std::size_t>(row_of_fine_[v])], foot_triangle_[v], base_positions));
    }
  });
  const auto unreferenced_from = static_cast<std::size_t>(triangle_rows_.back());
  for (std::size_t i = unreferenced_from; i < rows_.size(); ++i) store(rows_[i].vertex, Eigen::Vector3d(rows_[i].detail.data()));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, fine_of_base_.size(), kVertexGrain), [&](const auto& range) {
    for (std::size_t j = range.begin(); j != range.end(); ++j) store(fine_of_base_[j], base_positions.row(static_cast<Eigen::Index>(j)).transpose());
  });
}

void DetailEncoding::reconstruct(const Eigen::MatrixXd& base_positions, Eigen::MatrixXd& fine_positions, std::span<const int> vertices) const {
  check_base(base_positions);
  if (fine_positions.rows() != fine_count() || fine_positions.cols() != 3) {
    throw std::invalid_argument("DetailEncoding::reconstruct: a rebuild of some vertices needs the fine positions (" + std::to_string(fine_count()) +
                                "×3) to keep the others");
  }
  for (const int v : vertices) {
    if (v < 0 || v >= fine_count()) throw std::invalid_argument("DetailEncoding::reconstruct: vertex " + std::to_string(v) + " is not in the fine mesh");
  }
  const trace::Scope traced("fine mesh from the base, some vertices", "update");
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertices.size(), kVertexGrain), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const auto v = static_cast<std::size_t>(vertices[i]);
      if (const int own = base_of_fine_[v]; own >= 0) {
        fine_positions.row(vertices[i]) = base_positions.row(own);
        continue;
      }
      const FineRow& row = rows_[static_cast<std::size_t>(row_of_fine_[v])];
      const int t = foot_triangle_[v];
      if (t < 0) {
        fine_positions.row(vertices[i]) = Eigen::RowVector3d(row.detail.data());
      } else {
        fine_positions.row(vertices[i]) = position_of(row, t, base_positions).transpose();
      }
    }
  });
}

Eigen::VectorXd DetailEncoding::interpolate(const Eigen::VectorXd& base_values) const {
  if (base_values.size() != base_count_) throw std::invalid_argument("DetailEncoding::interpolate: one value per base vertex is needed");
  Eigen::VectorXd fine(fine_count());
  for (Eigen::Index v = 0; v < fine_count(); ++v) {
    const auto i = static_cast<std::size_t>(v);
    const int t = foot_triangle_[i];
    if (base_of_fine_[i] >= 0) fine[v] = base_values[base_of_fine_[i]];
    else if (t < 0) fine[v] = 0.0;
    else {
      const FineRow& row = rows_[static_cast<std::size_t>(row_of_fine_[i])];
      const double wb = row.wb, wc = row.wc;
      fine[v] = (1.0 - wb - wc) * base_values[base_triangles_(t, 0)] + wb * base_values[base_triangles_(t, 1)] +
                wc * base_values[base_triangles_(t, 2)];
    }
  }
  return fine;
}

std::array<int, 3> DetailEncoding::foot_corners(int fine_vertex) const {
  const int t = foot_triangle_[static_cast<std::size_t>(fine_vertex)];
  if (t < 0) return {-1, -1, -1};
  return {base_triangles_(t, 0), base_triangles_(t, 1), base_triangles_(t, 2)};
}

std::array<double, 3> DetailEncoding::foot_weights(int fine_vertex) const {
  const auto i = static_cast<std::size_t>(fine_vertex);
  if (foot_triangle_[i] < 0 || row_of_fine_[i] < 0) return {0.0, 0.0, 0.0};
  const FineRow& row = rows_[static_cast<std::size_t>(row_of_fine_[i])];
  return {1.0 - row.wb - row.wc, row.wb, row.wc};
}

}  // namespace hdeform

#include "edge_collapse.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <tuple>

#include "mesh/disjoint_sets.h"

namespace hdeform::detail {
namespace {

// A plane quadric: the symmetric 4×4 matrix of Σ (nᵀp + d)² over planes, as its ten entries.
struct Quadric {
  std::array<double, 10> q{};  // aa ab ac ad bb bc bd cc cd dd
  double weight = 0.0;         // Σ of the planes' weights
  double planes = 0.0;         // how many planes (weight / planes: their mean area)

  static Quadric plane(const Eigen::Vector3d& n, double d, double weight) {
    Quadric result;
    const double a = n.x(), b = n.y(), c = n.z();
    result.q = {a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d};
    for (double& value : result.q) value *= weight;
    result.weight = weight;
    result.planes = 1.0;
    return result;
  }
  Quadric& operator+=(const Quadric& other) {
    for (std::size_t i = 0; i < q.size(); ++i) q[i] += other.q[i];
    weight += other.weight;
    planes += other.planes;
    return *this;
  }
  double error(const Eigen::Vector3d& p) const {
    const double x = p.x(), y = p.y(), z = p.z();
    return q[0] * x * x + 2 * q[1] * x * y + 2 * q[2] * x * z + 2 * q[3] * x + q[4] * y * y + 2 * q[5] * y * z + 2 * q[6] * y +
           q[7] * z * z + 2 * q[8] * z + q[9];
  }
};

// cos of the largest turn of a triangle's normal a collapse may cause.
constexpr double kSmallestNormalCosine = 0.2;
// The shape a collapse may leave a triangle in (triangle_quality), unless it was worse before:
// slivers would make the base's cotangent weights, and so its field, poor.
constexpr double kSmallestQuality = 0.3;
// Where the quadric error cannot tell collapses apart (flat parts: a subdivided mesh is flat
// between its original vertices), the shorter edge goes first, which keeps the base even. The
// squared length counts at this fraction against the mean squared distance to the planes.
constexpr double kLengthWeight = 1e-3;

// 4√3 area / Σ squared edge lengths: 1 for an equilateral triangle, 0 for a degenerate one.
double triangle_quality(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double lengths = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  return lengths > 0 ? 2.0 * std::sqrt(3.0) * (b - a).cross(c - a).norm() / lengths : 0.0;
}

class Collapser {
 public:
  explicit Collapser(const Mesh& mesh) : triangles_(static_cast<std::size_t>(mesh.triangle_count())) {
    const auto n = static_cast<std::size_t>(mesh.vertex_count());
    positions_.resize(n);
    for (std::size_t v = 0; v < n; ++v) positions_[v] = mesh.positions.row(static_cast<Eigen::Index>(v)).transpose();
    around_.resize(n);
    quadric_.resize(n);
    removed_.assign(n, 0);
    locked_.assign(n, 0);
    referenced_.assign(n, 0);
    tbb::parallel_for(std::size_t{0}, triangles_.size(), [&](std::size_t t) {
      for (int k = 0; k < 3; ++k) triangles_[t][static_cast<std::size_t>(k)] = mesh.triangles(static_cast<Eigen::Index>(t), k);
    });
    // A triangle's plane, area-weighted (none for a degenerate one). Computed again at each of
    // its corners rather than kept: a list of every triangle's quadric would be 88 bytes a
    // triangle, 1.2 GB at 13 million, on top of what the inspection holds beside the collapses.
    auto plane_of = [&](int t) {
      const auto& corners = triangles_[static_cast<std::size_t>(t)];
      const Eigen::Vector3d a = point(corners[0]), b = point(corners[1]), c = point(corners[2]);
      const Eigen::Vector3d cross = (b - a).cross(c - a);
      const double area = 0.5 * cross.norm();
      if (!(area > 0)) return Quadric{};
      const Eigen::Vector3d normal = cross.normalized();
      return Quadric::plane(normal, -normal.dot(a), area);
    };
    // Each vertex's triangles, ascending (a triangle that repeats a corner twice over), gathered
    // by a counting sort; then each vertex's list and quadric side by side, the planes summed in
    // the triangles' order.
    std::vector<std::size_t> start(n + 1, 0);
    for (const auto& corners : triangles_) {
      for (const int v : corners) ++start[static_cast<std::size_t>(v) + 1];
    }
    for (std::size_t v = 0; v < n; ++v) start[v + 1] += start[v];
    std::vector<int> incident(start[n]);
    {
      std::vector<std::size_t> next(start.begin(), start.end() - 1);
      for (std::size_t t = 0; t < triangles_.size(); ++t) {
        for (const int v : triangles_[t]) incident[next[static_cast<std::size_t>(v)]++] = static_cast<int>(t);
      }
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t v = range.begin(); v != range.end(); ++v) {
        const auto first = incident.begin() + static_cast<std::ptrdiff_t>(start[v]), last = incident.begin() + static_cast<std::ptrdiff_t>(start[v + 1]);
        around_[v].assign(first, last);
        referenced_[v] = first != last ? 1 : 0;
        for (auto t = first; t != last; ++t) quadric_[v] += plane_of(*t);
      }
    });
    double total_area = 0.0, planes = 0.0;
    for (const Quadric& quadric : quadric_) {
      total_area += quadric.weight;
      planes += quadric.planes;
    }
    mean_triangle_area_ = planes > 0.0 ? total_area / planes : 0.0;
    alive_triangles_ = triangles_.size();
    alive_vertices_ = std::count(referenced_.begin(), referenced_.end(), 1);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& range) {
      FanScratch scratch;
      for (std::size_t v = range.begin(); v != range.end(); ++v) locked_[v] = !one_closed_fan(static_cast<int>(v), scratch);
    });
  }

  // What to collapse to for `requested` vertices. Each connected component's share of them is in
  // proportion to its vertices, but no component goes below what the collapses must keep of it:
  // its locked vertices (on a boundary or a non-manifold edge), or four (a tetrahedron) where it
  // has none. Where a share falls short of that, the difference is added to the target rather than
  // taken from the other components, so that a scan's debris (islands of a few triangles, which
  // keep every vertex) does not take the base's vertices from the surface being edited.
  Eigen::Index target_for(Eigen::Index requested) const {
    const auto n = around_.size();
    DisjointSets components(n);
    for (const auto& corners : triangles_) {
      components.unite(corners[0], corners[1]);
      components.unite(corners[1], corners[2]);
    }
    // Per component, at its root: its vertices, and those locked.
    std::vector<std::pair<int, int>> counts(n, {0, 0});
    for (std::size_t v = 0; v < n; ++v) {
      if (!referenced_[v]) continue;
      auto& [vertices, locked] = counts[static_cast<std::size_t>(components.find(static_cast<int>(v)))];
      ++vertices;
      locked += locked_[v];
    }
    const double share_per_vertex = static_cast<double>(requested) / static_cast<double>(std::max<Eigen::Index>(alive_vertices_, 1));
    double short_of_floors = 0.0;
    for (const auto& [vertices, locked] : counts) {
      if (vertices == 0) continue;
      const double floor = std::min(vertices, std::max(locked, 4));
      short_of_floors += std::max(0.0, floor - share_per_vertex * vertices);
    }
    return std::min(alive_vertices_, requested + static_cast<Eigen::Index>(std::llround(short_of_floors)));
  }

  // In passes, as meshoptimizer's simplifier does: each vertex's cheapest collapse is costed (in
  // parallel, again only where a collapse changed what it costs), and the pass takes the cheapest
  // of them, up to half the vertices, unless an earlier collapse of the pass changed their cost;
  // a refused one gives way to its vertex's cheapest allowed collapse when that is as cheap.
  void run(Eigen::Index target, const std::function<void(double)>& collapsed_share) {
    const Eigen::Index to_collapse = alive_vertices_ - target;
    std::vector<Candidate> candidates;
    stale_.assign(around_.size(), 0);
    dirty_.assign(around_.size(), 1);
    best_.assign(around_.size(), Candidate{-1.0, -1, -1, 0.0});
    // The vertices that may still collapse, ascending: the passes go through these alone, which
    // at the end are a tenth of the mesh or less.
    std::vector<int> movable;
    for (std::size_t u = 0; u < around_.size(); ++u) {
      if (referenced_[u] && !locked_[u]) movable.push_back(static_cast<int>(u));
    }
    std::vector<int> deferred;
    while (alive_vertices_ > target) {
      std::erase_if(movable, [&](int u) { return removed_[static_cast<std::size_t>(u)] != 0; });
      cost_candidates(movable);
      std::fill(dirty_.begin(), dirty_.end(), 0);
      candidates.clear();
      for (const int u : movable) {
        if (best_[static_cast<std::size_t>(u)].from >= 0) candidates.push_back(best_[static_cast<std::size_t>(u)]);
      }
      if (candidates.empty()) break;
      // The goal's cheapest candidates: at most that many collapses, each one candidate's.
      const Eigen::Index goal = std::min(alive_vertices_ - target, std::max<Eigen::Index>(1, alive_vertices_ / 2));
      const auto cut = candidates.begin() + std::min<std::ptrdiff_t>(goal - 1, static_cast<std::ptrdiff_t>(candidates.size()) - 1);
      std::nth_element(candidates.begin(), cut, candidates.end(), [](const Candidate& a, const Candidate& b) { return b > a; });
      const Candidate threshold = *cut;
      std::fill(stale_.begin(), stale_.end(), 0);
      // They are taken in vertex order, which is spatial (collapse_edges): each collapse finds
      // its neighbourhood in cache, where the order of cost would jump across the mesh. A large
      // mesh is cut into slabs of consecutive vertices, collapsed side by side; a collapse whose
      // neighbourhood leaves its slab waits for the pass over the whole mesh after them.
      // No two slabs touch the same vertex, so the result does not depend on the threads.
      const auto n = static_cast<std::size_t>(around_.size());
      const bool side_by_side = n >= kSlabs * kSmallestSlab;
      Outcome outcome;
      std::span<const int> rest = movable;
      if (side_by_side) {
        const std::size_t width = (n + kSlabs - 1) / kSlabs;
        std::vector<std::size_t> cuts{0};
        for (std::size_t at = width; at < n; at += width) cuts.push_back(at);
        cuts.push_back(n);
        std::vector<Outcome> outcomes(cuts.size() - 1);
        std::vector<std::vector<int>> slab_deferred(outcomes.size());
        tbb::parallel_for(std::size_t{0}, outcomes.size(), [&](std::size_t slab) {
          const auto first = std::lower_bound(movable.begin(), movable.end(), static_cast<int>(cuts[slab]));
          const auto last = std::lower_bound(first, movable.end(), static_cast<int>(cuts[slab + 1]));
          outcomes[slab] = collapse_range(static_cast<int>(cuts[slab]), static_cast<int>(cuts[slab + 1]), {first, last}, threshold,
                                          &slab_deferred[slab]);
        });
        for (const auto& part : outcomes) outcome.add(part);
        deferred.clear();
        for (const auto& part : slab_deferred) deferred.insert(deferred.end(), part.begin(), part.end());
        rest = deferred;
      }
      // What the slabs left: the collapses across their borders (a Morton order puts some
      // neighbours far apart), on this thread.
      outcome.add(collapse_range(0, static_cast<int>(n), rest, threshold, nullptr));
      alive_vertices_ -= outcome.collapsed;
      alive_triangles_ -= 2 * static_cast<std::size_t>(outcome.collapsed);
      largest_error_ = std::max(largest_error_, outcome.largest_error);
      if (outcome.collapsed == 0) break;
      if (collapsed_share && to_collapse > 0) {
        collapsed_share(std::min(1.0, static_cast<double>(to_collapse - (alive_vertices_ - target)) / static_cast<double>(to_collapse)));
      }
    }
  }

  CollapsedMesh result() const {
    CollapsedMesh collapsed;
    collapsed.kept.assign(around_.size(), 0);
    collapsed.triangles.resize(static_cast<Eigen::Index>(alive_triangles_), 3);
    Eigen::Index row = 0;
    for (const auto& corners : triangles_) {
      if (corners[0] < 0) continue;
      for (int k = 0; k < 3; ++k) {
        collapsed.triangles(row, k) = corners[static_cast<std::size_t>(k)];
        collapsed.kept[static_cast<std::size_t>(corners[static_cast<std::size_t>(k)])] = 1;
      }
      ++row;
    }
    collapsed.vertices = std::count(collapsed.kept.begin(), collapsed.kept.end(), 1);
    collapsed.largest_error = std::sqrt(std::max(0.0, largest_error_));
    return collapsed;
  }

 private:
  struct Candidate {
    double cost;
    int from, to;
    double squared_distance;  // the quadric's part of the cost: mean squared distance to the planes
    bool operator>(const Candidate& other) const {
      return std::tie(cost, from, to) > std::tie(other.cost, other.from, other.to);
    }
  };

  // Slabs of a large mesh's vertices, collapsed side by side; at fewer vertices per slab than
  // kSmallestSlab the border vertices would be most of them, and one thread goes through all.
  static constexpr std::size_t kSlabs = 16;
  static constexpr std::size_t kSmallestSlab = 4096;

  struct Outcome {
    Eigen::Index collapsed = 0;
    double largest_error = 0.0;
    void add(const Outcome& other) {
      collapsed += other.collapsed;
      largest_error = std::max(largest_error, other.largest_error);
    }
  };

  // One pass's collapses from `vertices` (ascending, in [begin, end)) with everything they touch
  // (both ends and their neighbours) inside [begin, end) too: the range's vertices are all this
  // call reads or writes of the mesh, so ranges that do not overlap run side by side. `deferred`
  // (when given) receives every vertex that may still collapse in this pass once the ranges'
  // borders are open: those whose collapse reached outside.
  Outcome collapse_range(int begin, int end, std::span<const int> vertices, const Candidate& threshold, std::vector<int>* deferred) {
    Outcome outcome;
    std::vector<int> ring_u, ring_v;
    auto inside = [&](int w) { return w >= begin && w < end; };
    auto neighbourhood_inside = [&](int u, int v) {
      neighbours(u, ring_u);
      if (!std::all_of(ring_u.begin(), ring_u.end(), inside)) return false;
      neighbours(v, ring_v);
      return std::all_of(ring_v.begin(), ring_v.end(), inside);
    };
    auto reaches_out = [&](int vertex) {
      if (deferred != nullptr) deferred->push_back(vertex);
    };
    for (const int vertex : vertices) {
      const Candidate candidate = best_[static_cast<std::size_t>(vertex)];
      if (candidate.from < 0 || candidate > threshold) continue;
      const auto u = static_cast<std::size_t>(candidate.from), v = static_cast<std::size_t>(candidate.to);
      if (stale_[u] || removed_[u] || removed_[v]) continue;
      if (!inside(candidate.to) || !neighbourhood_inside(candidate.from, candidate.to)) {
        reaches_out(vertex);
        continue;
      }
      Candidate chosen = candidate;
      if (!collapse_allowed(chosen.from, chosen.to, ring_u, ring_v, true)) {
        // Refused (a fold, a sliver, the link condition): u's next cheapest that is allowed, if
        // it is still among the pass's cheapest.
        const auto next = cheapest_allowed(chosen.from, ring_u, ring_v);
        best_[u] = next.value_or(Candidate{-1.0, -1, -1, 0.0});  // what the next passes see of u
        if (!next || *next > threshold) continue;
        if (!inside(next->to) || !neighbourhood_inside(next->from, next->to)) {
          reaches_out(vertex);
          continue;
        }
        chosen = *next;
      }
      const int survivor = chosen.to;
      collapse(chosen.from, survivor);
      // survivor's quadric changed: its own collapse and those onto it (or onto u) cost something
      // else now; they wait for the next pass, costed again. Every other candidate keeps its
      // cost, and is checked when it is taken.
      stale_[static_cast<std::size_t>(survivor)] = dirty_[static_cast<std::size_t>(survivor)] = 1;
      neighbours(survivor, ring_v);
      for (const int w : ring_v) {
        const auto target_of_w = best_[static_cast<std::size_t>(w)].to;
        // (−1: nothing was allowed; a changed neighbourhood may allow something now.)
        if (target_of_w == survivor || target_of_w == chosen.from || target_of_w < 0) {
          stale_[static_cast<std::size_t>(w)] = dirty_[static_cast<std::size_t>(w)] = 1;
        }
      }
      outcome.largest_error = std::max(outcome.largest_error, chosen.squared_distance);
      ++outcome.collapsed;
    }
    return outcome;
  }

  const Eigen::Vector3d& point(int v) const { return positions_[static_cast<std::size_t>(v)]; }

  // The distinct neighbours of v, through its live triangles (a fan holds a handful: a linear
  // search beats sorting).
  void neighbours(int v, std::vector<int>& out) const {
    out.clear();
    if (!locked_[static_cast<std::size_t>(v)]) {
      // One closed fan, oriented one way (one_closed_fan), and the collapses keep it so: each
      // neighbour follows v in exactly one triangle. (A collapse u → v puts u's side of its link
      // in place of u in v's link, and these share only the two opposite vertices, by the link
      // condition; in any other vertex's link, u merges with v where they were neighbours, and
      // becomes v where v was absent; a link of three, which the merge would pinch, is refused.)
      for (const int t : around_[static_cast<std::size_t>(v)]) {
        const auto& c = triangles_[static_cast<std::size_t>(t)];
        out.push_back(c[0] == v ? c[1] : c[1] == v ? c[2] : c[0]);
      }
      return;
    }
    for (const int t : around_[static_cast<std::size_t>(v)]) {
      for (const int w : triangles_[static_cast<std::size_t>(t)]) {
        if (w != v && std::find(out.begin(), out.end(), w) == out.end()) out.push_back(w);
      }
    }
  }

  // Whether v's triangles form one closed fan: every edge from v in exactly two of them, as many
  // triangles as neighbours, and the triangles connected around v.
  struct FanScratch {
    std::vector<std::pair<int, int>> rims;  // (neighbour before, neighbour after) per triangle
    std::vector<char> seen;
  };
  bool one_closed_fan(int v, FanScratch& scratch) const {
    const auto& fan = around_[static_cast<std::size_t>(v)];
    if (fan.size() < 3) return false;
    auto& rims = scratch.rims;
    rims.clear();
    for (const int t : fan) {
      const auto& c = triangles_[static_cast<std::size_t>(t)];
      const int k = c[0] == v ? 0 : c[1] == v ? 1 : 2;
      rims.emplace_back(c[static_cast<std::size_t>((k + 1) % 3)], c[static_cast<std::size_t>((k + 2) % 3)]);
    }
    // Walk the fan: from each triangle's far corner to the triangle that starts there.
    auto& seen = scratch.seen;
    seen.assign(rims.size(), 0);
    std::size_t at = 0, walked = 0;
    for (; walked < rims.size(); ++walked) {
      if (seen[at]) break;
      seen[at] = 1;
      const int next = rims[at].second;
      std::size_t found = rims.size(), count = 0;
      for (std::size_t i = 0; i < rims.size(); ++i) {
        if (rims[i].first == next) {
          found = i;
          ++count;
        }
      }
      if (count != 1) return false;
      at = found;
    }
    return walked == rims.size() && at == 0;
  }

  Candidate cost_of(int u, int v) const {
    Quadric sum = quadric_[static_cast<std::size_t>(u)];
    sum += quadric_[static_cast<std::size_t>(v)];
    const double squared_distance = std::max(0.0, sum.error(point(v))) / std::max(sum.weight, 1e-300);
    // Where the mesh's triangles are smaller than its mean, the cost is raised by the square
    // root of how much smaller, so that a base triangle there does not lie over many more fine
    // triangles than elsewhere: the rebuild moves a foot linearly with its base triangle, and where
    // the surface is strongly curved and bends inside a large one, small triangles fold. Raised
    // only, never lowered: lowering it where the triangles are large starved those parts of other
    // meshes (docs/performance.md, "A base denser where the scan is dense").
    const double mean_area = sum.weight / std::max(sum.planes, 1.0);
    const double denser = mean_area > 0.0 && mean_area < mean_triangle_area_ ? std::sqrt(mean_triangle_area_ / mean_area) : 1.0;
    return {(squared_distance + kLengthWeight * (point(v) - point(u)).squaredNorm()) * denser, u, v, squared_distance};
  }

  // The cheapest collapse of every one of `vertices` that is unlocked and marked dirty, along one of its edges (whether
  // it is allowed is asked when it is taken).
  void cost_candidates(std::span<const int> vertices) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertices.size(), 4096), [&](const auto& range) {
      std::vector<int> ring;
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const auto u = static_cast<std::size_t>(vertices[i]);
        if (!dirty_[u] || removed_[u] || locked_[u] || !referenced_[u]) continue;
        best_[u] = Candidate{-1.0, -1, -1, 0.0};
        neighbours(static_cast<int>(u), ring);
        for (const int v : ring) {
          const Candidate candidate = cost_of(static_cast<int>(u), v);
          if (best_[u].from < 0 || best_[u] > candidate) best_[u] = candidate;
        }
      }
    });
  }

  // u's cheapest allowed collapse, if any. ring_u holds u's neighbours; ring_v is scratch space.
  std::optional<Candidate> cheapest_allowed(int u, const std::vector<int>& ring_u, std::vector<int>& ring_v) const {
    std::optional<Candidate> best;
    for (const int v : ring_u) {
      const Candidate candidate = cost_of(u, v);
      if ((!best || *best > candidate) && collapse_allowed(u, v, ring_u, ring_v, false)) best = candidate;
    }
    return best;
  }

  // ring_u holds u's neighbours; ring_v holds v's when `ring_v_ready`, else it is scratch space,
  // filled only once the cheaper tests pass.
  bool collapse_allowed(int u, int v, const std::vector<int>& ring_u, std::vector<int>& ring_v, bool ring_v_ready) const {
    if (locked_[static_cast<std::size_t>(u)]) return false;
    // The triangles on the edge, and their far corners.
    std::array<int, 2> opposite{-1, -1};
    int on_edge = 0;
    for (const int t : around_[static_cast<std::size_t>(u)]) {
      const auto& c = triangles_[static_cast<std::size_t>(t)];
      if (c[0] != v && c[1] != v && c[2] != v) continue;
      if (on_edge == 2) return false;
      for (const int w : c) {
        if (w != u && w != v) opposite[static_cast<std::size_t>(on_edge)] = w;
      }
      ++on_edge;
    }
    if (on_edge != 2) return false;
    // Link condition.
    if (!ring_v_ready) neighbours(v, ring_v);
    std::size_t shared = 0;
    for (const int w : ring_u) {
      if (std::find(ring_v.begin(), ring_v.end(), w) == ring_v.end()) continue;
      if (w != opposite[0] && w != opposite[1]) return false;
      ++shared;
    }
    if (shared != 2) return false;
    // An opposite vertex loses a neighbour: it keeps three at least (an interior vertex has as
    // many neighbours as triangles; one on the boundary one more, so this errs on the safe side).
    for (const int w : opposite) {
      if (around_[static_cast<std::size_t>(w)].size() <= 3) return false;
    }
    // No fold: the triangles that stay, with u moved onto v.
    const Eigen::Vector3d target = point(v);
    for (const int t : around_[static_cast<std::size_t>(u)]) {
      const auto& c = triangles_[static_cast<std::size_t>(t)];
      if (c[0] == v || c[1] == v || c[2] == v) continue;
      const Eigen::Vector3d a = point(c[0]), b = point(c[1]), d = point(c[2]);
      const Eigen::Vector3d before = (b - a).cross(d - a);
      const Eigen::Vector3d a2 = c[0] == u ? target : a, b2 = c[1] == u ? target : b, d2 = c[2] == u ? target : d;
      const Eigen::Vector3d after = (b2 - a2).cross(d2 - a2);
      const double lengths = before.norm() * after.norm();
      if (!(lengths > 0) || before.dot(after) < kSmallestNormalCosine * lengths) return false;
      const double quality = triangle_quality(a2, b2, d2);
      if (quality < kSmallestQuality && quality < triangle_quality(a, b, d)) return false;
    }
    return true;
  }

  void collapse(int u, int v) {
    auto& from = around_[static_cast<std::size_t>(u)];
    auto& to = around_[static_cast<std::size_t>(v)];
    for (const int t : from) {
      auto& c = triangles_[static_cast<std::size_t>(t)];
      if (c[0] == v || c[1] == v || c[2] == v) {
        // One of the edge's two triangles: gone, from every corner's list.
        for (const int w : c) {
          if (w == u) continue;
          auto& list = around_[static_cast<std::size_t>(w)];
          list.erase(std::find(list.begin(), list.end(), t));
        }
        c = {-1, -1, -1};
      } else {
        for (int& w : c) {
          if (w == u) w = v;
        }
        to.push_back(t);
      }
    }
    from.clear();
    removed_[static_cast<std::size_t>(u)] = 1;
    quadric_[static_cast<std::size_t>(v)] += quadric_[static_cast<std::size_t>(u)];
  }

  std::vector<Eigen::Vector3d> positions_;
  std::vector<std::array<int, 3>> triangles_;  // {−1, −1, −1}: collapsed away
  std::vector<std::vector<int>> around_;       // live triangles per vertex
  std::vector<Quadric> quadric_;
  double mean_triangle_area_ = 0.0;  // of the mesh's triangles, with a plane (not degenerate)
  std::vector<char> removed_, locked_, referenced_;
  std::vector<char> stale_, dirty_;  // per pass: cost changed in it; to be costed again
  std::vector<Candidate> best_;  // per vertex: its cheapest collapse (from −1: none)
  Eigen::Index alive_vertices_ = 0;
  std::size_t alive_triangles_ = 0;
  double largest_error_ = 0.0;
};

// Vertices renumbered along a Morton curve of their positions (ties by index), and triangles by
// their first vertex in that order: neighbours then sit close together in memory, and the serial
// collapses, which chase neighbourhoods, run several times faster on a scan whose file order
// is not spatial.
std::vector<int> spatial_order(const Eigen::MatrixXd& positions) {
  const auto n = positions.rows();
  std::vector<std::pair<std::uint64_t, int>> keys(static_cast<std::size_t>(n));
  const Eigen::RowVector3d low = n > 0 ? Eigen::RowVector3d(positions.colwise().minCoeff()) : Eigen::RowVector3d::Zero();
  const Eigen::RowVector3d extent = n > 0 ? Eigen::RowVector3d(Eigen::RowVector3d(positions.colwise().maxCoeff()) - low) : Eigen::RowVector3d::Ones();
  const double scale = 2097151.0 / std::max(extent.maxCoeff(), 1e-300);  // 21 bits per axis
  auto spread = [](std::uint64_t x) {
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffff;
    x = (x | x << 16) & 0x1f0000ff0000ff;
    x = (x | x << 8) & 0x100f00f00f00f00f;
    x = (x | x << 4) & 0x10c30c30c30c30c3;
    x = (x | x << 2) & 0x1249249249249249;
    return x;
  };
  tbb::parallel_for(Eigen::Index{0}, n, [&](Eigen::Index v) {
    std::uint64_t code = 0;
    for (int k = 0; k < 3; ++k) code |= spread(static_cast<std::uint64_t>((positions(v, k) - low[k]) * scale)) << k;
    keys[static_cast<std::size_t>(v)] = {code, static_cast<int>(v)};
  });
  tbb::parallel_sort(keys.begin(), keys.end());  // distinct keys: one order on any threads
  std::vector<int> order(keys.size());
  for (std::size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
  return order;
}

}  // namespace

CollapsedMesh collapse_edges(const Mesh& mesh, Eigen::Index target_vertices, const std::function<void(double)>& collapsed_share) {
  const std::vector<int> order = spatial_order(mesh.positions);  // new → old
  std::vector<int> rank(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) rank[static_cast<std::size_t>(order[i])] = static_cast<int>(i);
  Mesh ordered;
  ordered.positions.resize(mesh.vertex_count(), 3);
  tbb::parallel_for(std::size_t{0}, order.size(), [&](std::size_t i) { ordered.positions.row(static_cast<Eigen::Index>(i)) = mesh.positions.row(order[i]); });
  // Triangles by their first vertex in the new order, ties by index: a counting sort on it.
  std::vector<int> first(static_cast<std::size_t>(mesh.triangle_count()));
  tbb::parallel_for(Eigen::Index{0}, mesh.triangle_count(), [&](Eigen::Index t) {
    first[static_cast<std::size_t>(t)] = std::min({rank[static_cast<std::size_t>(mesh.triangles(t, 0))], rank[static_cast<std::size_t>(mesh.triangles(t, 1))],
                                                   rank[static_cast<std::size_t>(mesh.triangles(t, 2))]});
  });
  std::vector<Eigen::Index> by_first(first.size());
  {
    std::vector<std::size_t> next(order.size() + 1, 0);
    for (const int r : first) ++next[static_cast<std::size_t>(r) + 1];
    for (std::size_t r = 0; r < order.size(); ++r) next[r + 1] += next[r];
    for (std::size_t t = 0; t < first.size(); ++t) by_first[next[static_cast<std::size_t>(first[t])]++] = static_cast<Eigen::Index>(t);
  }
  ordered.triangles.resize(mesh.triangle_count(), 3);
  tbb::parallel_for(std::size_t{0}, by_first.size(), [&](std::size_t i) {
    for (int k = 0; k < 3; ++k) {
      ordered.triangles(static_cast<Eigen::Index>(i), k) = rank[static_cast<std::size_t>(mesh.triangles(by_first[i], k))];
    }
  });
  Collapser collapser(ordered);
  collapser.run(collapser.target_for(target_vertices), collapsed_share);
  CollapsedMesh collapsed = collapser.result();
  // Back to the input's numbering.
  std::vector<char> kept(collapsed.kept.size(), 0);
  for (std::size_t i = 0; i < order.size(); ++i) kept[static_cast<std::size_t>(order[i])] = collapsed.kept[i];
  collapsed.kept = std::move(kept);
  for (Eigen::Index t = 0; t < collapsed.triangles.rows(); ++t) {
    for (int k = 0; k < 3; ++k) collapsed.triangles(t, k) = order[static_cast<std::size_t>(collapsed.triangles(t, k))];
  }
  return collapsed;
}

}  // namespace hdeform::detail

#include "hdeform/correspondence.h"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

namespace hdeform {
namespace {


// A lower bound computed in floating point may round above the true one; pruning a little less
// keeps the search exact.
constexpr double kBoundSlack = 1e-9;
constexpr int kLeafSize = 12;
constexpr int kParallelBuild = 2048;  // points below which a subtree is built on one thread

// Eight doubles side by side: GCC lowers their arithmetic to the instruction set of the clone it
// compiles (one AVX-512 register, two AVX2 or four SSE2 ones), lane by lane, so every clone sums
// the same products in the same order and the distances are the same bits on any machine.
typedef double Lanes __attribute__((vector_size(64)));
typedef long long LaneMask __attribute__((vector_size(64)));
constexpr int kLanes = 8;

// The clones are chosen by an ifunc resolver that runs while the program is being relocated,
// before a sanitizer's runtime is up; instrumented, it crashes there (ThreadSanitizer did). The
// sanitizer builds run the baseline alone: the same lanes, the same arithmetic.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define HDEFORM_LANE_CLONES
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define HDEFORM_LANE_CLONES
#endif
#endif
#ifndef HDEFORM_LANE_CLONES
#define HDEFORM_LANE_CLONES [[gnu::target_clones("avx512f", "avx2", "default")]]
#endif

// (By reference: a 64-byte vector returned by value would change the calling convention between
// the clones.)
inline void load_lanes(Lanes& lanes, const double* values) { std::memcpy(&lanes, values, sizeof lanes); }
inline double sum_of(const Lanes& lanes) { return ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7])); }
inline void keep_positive(Lanes& lanes) {
  const Lanes zero = {};
  lanes = reinterpret_cast<Lanes>(reinterpret_cast<LaneMask>(lanes) & (lanes > zero));
}

// Σ (a_c − b_c)² over the k components, in blocks of 16 with the running sum checked after each:
// past `limit`, a partial sum above it (the sum only grows).
HDEFORM_LANE_CLONES double squared_distance_lanes(const double* a, const double* b, int k, double limit) {
  Lanes sum = {};
  int c = 0;
  for (; c + 2 * kLanes <= k; c += 2 * kLanes) {
    for (int half = 0; half < 2; ++half) {
      Lanes x, y;
      load_lanes(x, a + c + half * kLanes);
      load_lanes(y, b + c + half * kLanes);
      const Lanes d = x - y;
      sum += d * d;
    }
    if (const double total = sum_of(sum); total > limit) return total;
  }
  double total = sum_of(sum);
  for (; c < k; ++c) total += (a[c] - b[c]) * (a[c] - b[c]);
  return total;
}

// Σ gap_c² from the query to the box [low, high] over the k components, likewise.
HDEFORM_LANE_CLONES double box_distance_lanes(const double* query, const double* low, const double* high, int k,
                                                                             double limit) {
  Lanes sum = {};
  int c = 0;
  for (; c + 2 * kLanes <= k; c += 2 * kLanes) {
    for (int half = 0; half < 2; ++half) {
      const int at = c + half * kLanes;
      Lanes q, below, above;
      load_lanes(q, query + at);
      load_lanes(below, low + at);
      load_lanes(above, high + at);
      below -= q;
      above = q - above;
      keep_positive(below);
      keep_positive(above);
      const Lanes gap = below + above;
      sum += gap * gap;
    }
    if (const double total = sum_of(sum); total > limit) return total;
  }
  double total = sum_of(sum);
  for (; c < k; ++c) {
    const double gap = std::max(low[c] - query[c], 0.0) + std::max(query[c] - high[c], 0.0);
    total += gap * gap;
  }
  return total;
}

// The source coordinates in a binary tree whose nodes each know the box around their points, in
// all k components. The coordinates of a surface form a two-dimensional sheet in k dimensions:
// splitting along the sheet's long extent shrinks a node's box in every component at once, where
// a k-d tree splits along one coordinate at a time and bounds a query's distance by the few
// coordinates split on its path. The box bound holds for a distance over any subset of the
// components too: it is a sum over components.
class CoordinateTree {
 public:
  explicit CoordinateTree(CoordinateRows&& source)
      : k_(static_cast<int>(source.cols())), nodes_(static_cast<std::size_t>(node_count(static_cast<int>(source.rows())))),
        low_(nodes_.size() * static_cast<std::size_t>(k_)), high_(low_.size()), index_(static_cast<std::size_t>(source.rows())) {
    const auto count = static_cast<int>(source.rows());
    std::iota(index_.begin(), index_.end(), 0);
    std::vector<double> projection(static_cast<std::size_t>(count));
    build(source, 0, 0, count, projection);
    // The rows in tree order, in place (a leaf's rows side by side): each cycle of the
    // permutation followed with one row in hand, where a copy would write as much memory again.
    points_ = std::move(source);
    position_.resize(static_cast<std::size_t>(count));
    std::vector<char> placed(static_cast<std::size_t>(count), 0);
    Eigen::RowVectorXd held(k_);
    for (int start = 0; start < count; ++start) {
      position_[static_cast<std::size_t>(index_[static_cast<std::size_t>(start)])] = start;
      if (placed[static_cast<std::size_t>(start)] != 0) continue;
      held = points_.row(start);
      int p = start;
      for (int from = index_[static_cast<std::size_t>(p)]; from != start; p = from, from = index_[static_cast<std::size_t>(p)]) {
        points_.row(p) = points_.row(from);
        placed[static_cast<std::size_t>(p)] = 1;
      }
      points_.row(p) = held;
      placed[static_cast<std::size_t>(p)] = 1;
    }
  }

  // The source row nearest to `query` over `components` (all k when empty), ties to the lower
  // row; `guess`, any row (best one near the answer), only tightens the search from the start.
  std::pair<int, double> nearest(const double* query, const std::vector<int>& components, int guess) const {
    Search search{query, components, guess, squared_distance(query, components, points_.row(position_[static_cast<std::size_t>(guess)]).data())};
    search.prune_above = prune_limit(search.best_squared);
    if (box_distance(0, search, search.prune_above) <= search.prune_above) visit(0, search);
    return {search.best, std::sqrt(search.best_squared)};
  }

 private:
  struct Node {
    int begin = 0, end = 0;
    int right = -1;  // the left child is the next node; -1 for a leaf
  };
  struct Search {
    const double* query;
    const std::vector<int>& components;
    int best;
    double best_squared;
    double prune_above = 0.0;
  };

  // The tree's shape depends on the number of points alone (splits at the median), so each
  // subtree's nodes have known places and the halves are built in parallel.
  static int node_count(int points) { return points <= kLeafSize ? 1 : 1 + node_count(points / 2) + node_count(points - points / 2); }

  // A bound computed in floating point may round above the true one: a node is pruned only
  // when its bound exceeds the best distance by more than rounding can explain.
  static double prune_limit(double best_squared) { return best_squared * (1.0 + kBoundSlack); }

  void build(const CoordinateRows& source, int node, int begin, int end, std::vector<double>& projection) {
    const auto offset = static_cast<std::size_t>(node) * static_cast<std::size_t>(k_);
    Eigen::Map<Eigen::RowVectorXd> low(low_.data() + offset, k_), high(high_.data() + offset, k_);
    auto row = [&](int p) { return source.row(index_[static_cast<std::size_t>(p)]); };
    low = row(begin);
    high = row(begin);
    for (int p = begin + 1; p < end; ++p) {
      low = low.cwiseMin(row(p));
      high = high.cwiseMax(row(p));
    }
    nodes_[static_cast<std::size_t>(node)] = {begin, end, -1};
    if (end - begin <= kLeafSize) return;
    // Split at the median along the line from the point farthest from the box's centre to the
    // point farthest from that one: the sheet's long extent, without an eigen-decomposition.
    auto farthest_from = [&](const Eigen::RowVectorXd& from) {
      int far = begin;
      double widest = -1.0;
      for (int p = begin; p < end; ++p) {
        const double squared = (row(p) - from).squaredNorm();
        if (squared > widest) widest = squared, far = p;
      }
      return row(far).eval();
    };
    const Eigen::RowVectorXd from = farthest_from(0.5 * (low + high));
    const Eigen::RowVectorXd direction = farthest_from(from) - from;
    for (int p = begin; p < end; ++p) projection[static_cast<std::size_t>(index_[static_cast<std::size_t>(p)])] = row(p).dot(direction);
    const int middle = begin + (end - begin) / 2;
    std::nth_element(index_.begin() + begin, index_.begin() + middle, index_.begin() + end, [&](int a, int b) {
      return projection[static_cast<std::size_t>(a)] < projection[static_cast<std::size_t>(b)] ||
             (projection[static_cast<std::size_t>(a)] == projection[static_cast<std::size_t>(b)] && a < b);
    });
    const int left = node + 1;
    const int right = left + node_count(middle - begin);
    nodes_[static_cast<std::size_t>(node)].right = right;
    if (end - begin < kParallelBuild) {
      build(source, left, begin, middle, projection);
      build(source, right, middle, end, projection);
    } else {
      tbb::parallel_invoke([&] { build(source, left, begin, middle, projection); }, [&] { build(source, right, middle, end, projection); });
    }
  }

  // The squared distance over the components; past `limit`, a partial sum above it.
  double squared_distance(const double* query, const std::vector<int>& components, const double* point,
                          double limit = std::numeric_limits<double>::infinity()) const {
    if (components.empty()) return squared_distance_lanes(query, point, k_, limit);
    double squared = 0.0;
    for (const int c : components) squared += (query[c] - point[c]) * (query[c] - point[c]);
    return squared;
  }

  // The squared distance from the query to the node's box; once it exceeds `limit`, a partial
  // sum above it (the sum only grows), so that most far nodes are known far after a few blocks.
  double box_distance(int node, const Search& search, double limit) const {
    const auto offset = static_cast<std::size_t>(node) * static_cast<std::size_t>(k_);
    const double* low = low_.data() + offset;
    const double* high = high_.data() + offset;
    double to_box = 0.0;
    if (search.components.empty()) return box_distance_lanes(search.query, low, high, k_, limit);
    for (const int c : search.components) {
      const double q = search.query[c];
      const double gap = std::max(low[c] - q, 0.0) + std::max(q - high[c], 0.0);
      to_box += gap * gap;
    }
    return to_box;
  }

  void visit(int node, Search& search) const {
    const Node& here = nodes_[static_cast<std::size_t>(node)];
    if (here.right < 0) {
      for (int p = here.begin; p < here.end; ++p) {
        const double squared = squared_distance(search.query, search.components, points_.row(p).data(), search.best_squared);
        const int index = index_[static_cast<std::size_t>(p)];
        if (squared < search.best_squared || (squared == search.best_squared && index < search.best)) {
          search.best_squared = squared;
          search.best = index;
          search.prune_above = prune_limit(squared);
        }
      }
      return;
    }
    const double left_bound = box_distance(node + 1, search, search.prune_above);
    const double right_bound = box_distance(here.right, search, search.prune_above);
    const int first = left_bound <= right_bound ? node + 1 : here.right;
    const int second = first == here.right ? node + 1 : here.right;
    if (std::min(left_bound, right_bound) <= search.prune_above) visit(first, search);
    if (std::max(left_bound, right_bound) <= search.prune_above) visit(second, search);
  }

  int k_;
  std::vector<Node> nodes_;
  std::vector<double> low_, high_;  // per node, the box: k each
  std::vector<int> index_;          // tree order → source row
  std::vector<int> position_;       // source row → tree order
  CoordinateRows points_;           // the source rows in tree order
};

// The matching of `target_count` queries, query t's k values given by query_row(t, buffer) (a
// buffer of 4k doubles per thread to form it in).
template <class QueryRow>
TriangleMatch match(Eigen::Index target_count, int k, QueryRow&& query_row, CoordinateRows source, int top_n) {
  if (top_n != 0 && (top_n < 3 || top_n > k)) {
    throw std::invalid_argument("top-n must be between 3 and the number of markers (" + std::to_string(k) + "), got " + std::to_string(top_n));
  }
  TriangleMatch match;
  match.source.assign(static_cast<std::size_t>(target_count), -1);
  match.distance.assign(static_cast<std::size_t>(target_count), 0.0);
  if (target_count == 0 || source.rows() == 0) return match;
  if (top_n == k) top_n = 0;

  const CoordinateTree tree{std::move(source)};
  // Neighbouring target triangles (mostly neighbours in the file's order, too) have nearby
  // matches: each query starts from the previous one's answer.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, target_count, 128), [&](const auto& range) {
    std::vector<int> components;
    std::vector<int> order(static_cast<std::size_t>(k));
    std::vector<double> buffer(4 * static_cast<std::size_t>(k));
    int guess = 0;
    for (Eigen::Index t = range.begin(); t != range.end(); ++t) {
      const double* query = query_row(t, buffer.data());
      if (top_n > 0) {
        // The n largest components, ties to the lower index.
        std::iota(order.begin(), order.end(), 0);
        std::partial_sort(order.begin(), order.begin() + top_n, order.end(),
                          [&](int a, int b) { return query[a] > query[b] || (query[a] == query[b] && a < b); });
        components.assign(order.begin(), order.begin() + top_n);
        std::sort(components.begin(), components.end());
      }
      const auto [nearest, distance] = tree.nearest(query, components, guess);
      match.source[static_cast<std::size_t>(t)] = nearest;
      match.distance[static_cast<std::size_t>(t)] = distance;
      guess = nearest;
    }
  });
  return match;
}

}  // namespace

TriangleMatch match_triangles(const CoordinateRows& target, CoordinateRows source, int top_n) {
  const auto k = static_cast<int>(source.cols());
  if (target.cols() != k) throw std::invalid_argument("match_triangles: target and source coordinates differ in length");
  return match(target.rows(), k, [&](Eigen::Index t, double*) { return target.row(t).data(); }, std::move(source), top_n);
}

TriangleMatch match_triangles(const VertexCoordinates& target, const Eigen::MatrixXi& target_triangles, CoordinateRows source, int top_n) {
  const int k = target.columns();
  if (source.cols() != k) throw std::invalid_argument("match_triangles: target and source coordinates differ in length");
  return match(target_triangles.rows(), k, [&](Eigen::Index t, double* buffer) {
    target.triangle_row(target_triangles, t, buffer, buffer + k);
    return static_cast<const double*>(buffer);
  }, std::move(source), top_n);
}

}  // namespace hdeform

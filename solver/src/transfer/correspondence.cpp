#include "hdeform/correspondence.h"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include "hdeform/trace.h"
#include "target_clones.h"

namespace hdeform {
namespace {

constexpr int kLeafSize = 12;
constexpr int kParallelBuild = 2048;  // points below which a subtree is built on one thread
constexpr int kDirectionSample = 256;  // rows that choose a node's split

// The search screens with single-precision copies of the coordinates (half the memory to read,
// twice the lanes) and decides with the double ones: a node or a row is passed over only when its
// single-precision sum proves its double distance above the best so far (CoordinateTree::
// screen_limit), so the answer is the double search's, ties included.
constexpr double kFloatUnit = 0x1p-24;  // single precision's unit roundoff
constexpr double kFloatTiny = 0x1p-149;  // its smallest subnormal: the most an underflow loses
// The double distances compared against each other are each within this factor of the exact one
// (about k·2⁻⁵³): a screen lets through anything within it of the best.
constexpr double kDoubleSlack = 1e-9;

// Sixteen floats side by side: GCC lowers their arithmetic to the instruction set of the clone it
// compiles (one AVX-512 register, two AVX2 or four SSE2 ones), lane by lane.
typedef float Lanes __attribute__((vector_size(64)));
typedef int LaneMask __attribute__((vector_size(64)));
typedef float HalfLanes __attribute__((vector_size(32)));
typedef float QuarterLanes __attribute__((vector_size(16)));
constexpr int kLanes = 16;
constexpr int kBlock = 2 * kLanes;  // components summed between two checks against the limit

// (By reference: a 64-byte vector returned by value would change the calling convention between
// the clones.)
inline void load_lanes(Lanes& lanes, const float* values) { std::memcpy(&lanes, values, sizeof lanes); }
inline float sum_of(const Lanes& lanes) {
  HalfLanes low, high;
  std::memcpy(&low, &lanes, sizeof low);
  std::memcpy(&high, reinterpret_cast<const char*>(&lanes) + sizeof low, sizeof high);
  const HalfLanes half = low + high;
  QuarterLanes first, second;
  std::memcpy(&first, &half, sizeof first);
  std::memcpy(&second, reinterpret_cast<const char*>(&half) + sizeof first, sizeof second);
  const QuarterLanes quarter = first + second;
  return (quarter[0] + quarter[1]) + (quarter[2] + quarter[3]);
}
inline void keep_positive(Lanes& lanes) {
  const Lanes zero = {};
  lanes = reinterpret_cast<Lanes>(reinterpret_cast<LaneMask>(lanes) & (lanes > zero));
}

// Σ (a_c − b_c)² over `padded` components (a multiple of kBlock), the running sum checked after
// each block: past `limit`, a partial sum above it (a float sum of squares never decreases).
HDEFORM_TARGET_CLONES("avx512f", "avx2", "default") float squared_distance_lanes(const float* a, const float* b, int padded, float limit) {
  Lanes sum = {};
  float total = 0.0F;
  for (int c = 0; c < padded; c += kBlock) {
    for (int half = 0; half < 2; ++half) {
      Lanes x, y;
      load_lanes(x, a + c + half * kLanes);
      load_lanes(y, b + c + half * kLanes);
      const Lanes d = x - y;
      sum += d * d;
    }
    total = sum_of(sum);
    if (total > limit) return total;
  }
  return total;
}

// Σ gap_c² from the query to the box [low, high] over `padded` components, likewise.
HDEFORM_TARGET_CLONES("avx512f", "avx2", "default") float box_distance_lanes(const float* query, const float* low, const float* high, int padded, float limit) {
  Lanes sum = {};
  float total = 0.0F;
  for (int c = 0; c < padded; c += kBlock) {
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
    total = sum_of(sum);
    if (total > limit) return total;
  }
  return total;
}

// Σ (a_c − b_c)² over k components in double, in blocks of eight, checked against `limit`
// likewise: the distance every answer is decided by.
double squared_distance(const double* a, const double* b, int k, double limit) {
  double total = 0.0;
  int c = 0;
  for (; c + 8 <= k; c += 8) {
    double block = 0.0;
    for (int j = c; j < c + 8; ++j) block += (a[j] - b[j]) * (a[j] - b[j]);
    total += block;
    if (total > limit) return total;
  }
  for (; c < k; ++c) total += (a[c] - b[c]) * (a[c] - b[c]);
  return total;
}

// The nearest float at or above `x`.
float float_above(double x) {
  const auto rounded = static_cast<float>(x);
  return static_cast<double>(rounded) < x ? std::nextafter(rounded, std::numeric_limits<float>::infinity()) : rounded;
}

int padded_length(int k) { return (k + kBlock - 1) / kBlock * kBlock; }

// Rows of k doubles are formed on demand, `row(r, buffer)`, in a buffer of this many doubles:
// written rows, or a triangle's from its corners' (its mean and three corners).
std::size_t row_buffer_length(int k) { return 4 * static_cast<std::size_t>(k); }

// The source coordinates in a binary tree whose nodes each know the box around their points, in
// all k components. The coordinates of a surface form a two-dimensional sheet in k dimensions:
// splitting along the sheet's long extent shrinks a node's box in every component at once, where
// a k-d tree splits along one coordinate at a time and bounds a query's distance by the few
// coordinates split on its path. The box bound holds for a distance over any subset of the
// components too: it is a sum over components.
//
// The tree holds only the single-precision copy of the rows; a row's double values, which decide,
// are formed again when a row passes the screen (a few per query).
template <class SourceRow>
class CoordinateTree {
 public:
  CoordinateTree(Eigen::Index count, int k, const SourceRow& source_row)
      : k_(k), padded_(padded_length(k)), source_row_(source_row), nodes_(static_cast<std::size_t>(node_count(static_cast<int>(count)))),
        low_(nodes_.size() * static_cast<std::size_t>(padded_)), high_(low_.size()), index_(static_cast<std::size_t>(count)),
        screen_(new float[static_cast<std::size_t>(count) * static_cast<std::size_t>(padded_)]) {
    // The rows rounded to single precision, padded with zeros, first written by the threads so
    // that the pages fault in on both cores.
    largest_norm_ = tbb::parallel_reduce(
        tbb::blocked_range<Eigen::Index>(0, count, 512), 0.0,
        [&](const tbb::blocked_range<Eigen::Index>& range, double largest) {
          std::vector<double> buffer(row_buffer_length(k_));
          for (Eigen::Index r = range.begin(); r != range.end(); ++r) {
            const double* row = source_row_(r, buffer.data());
            float* out = screen_row(static_cast<int>(r));
            for (int c = 0; c < k_; ++c) out[c] = static_cast<float>(row[c]);
            std::fill(out + k_, out + padded_, 0.0F);
            largest = std::max(largest, Eigen::Map<const Eigen::RowVectorXd>(row, k_).norm());
          }
          return largest;
        },
        [](double a, double b) { return std::max(a, b); });
    std::iota(index_.begin(), index_.end(), 0);
    std::vector<float> projection(static_cast<std::size_t>(count));
    build(0, 0, static_cast<int>(count), projection);
    // The rows in tree order, in place (a leaf's rows side by side): each cycle of the
    // permutation followed with one row in hand, where a copy would write as much memory again.
    std::vector<char> placed(static_cast<std::size_t>(count), 0);
    std::vector<float> held(static_cast<std::size_t>(padded_));
    const auto row_bytes = static_cast<std::size_t>(padded_) * sizeof(float);
    for (int start = 0; start < static_cast<int>(count); ++start) {
      if (placed[static_cast<std::size_t>(start)] != 0) continue;
      std::memcpy(held.data(), screen_row(start), row_bytes);
      int p = start;
      for (int from = index_[static_cast<std::size_t>(p)]; from != start; p = from, from = index_[static_cast<std::size_t>(p)]) {
        std::memcpy(screen_row(p), screen_row(from), row_bytes);
        placed[static_cast<std::size_t>(p)] = 1;
      }
      std::memcpy(screen_row(p), held.data(), row_bytes);
      placed[static_cast<std::size_t>(p)] = 1;
    }
    // A float sum of n non-negative terms, each a rounded square of a rounded difference, is
    // within (n + 2)u/(1 − (n + 2)u) of the exact sum of the rounded values; doubled for the
    // rounding of the limit itself.
    const double terms = static_cast<double>(padded_ + 2) * kFloatUnit;
    sum_error_ = terms < 0.25 ? 2.0 * terms / (1.0 - terms) : std::numeric_limits<double>::infinity();
  }

  int padded() const { return padded_; }

  // The source row nearest to `query` over `components` (all k when empty), ties to the lower
  // row; `screen_query` is the query in single precision, padded with zeros; `buffer` holds
  // row_buffer_length(k) doubles. `guess`, any row (best one near the answer), only tightens the
  // search from the start.
  std::pair<int, double> nearest(const double* query, const float* screen_query, const std::vector<int>& components, int guess,
                                 double* buffer) const {
    // How far the rounding to single precision can move a distance: each component by at most
    // u|x| (or an underflow), so a distance by u(‖query‖ + ‖row‖) at most.
    const double norm = Eigen::Map<const Eigen::RowVectorXd>(query, k_).norm();
    const double margin = 1.01 * kFloatUnit * (norm + largest_norm_) + 2.0 * static_cast<double>(k_) * kFloatTiny;
    Search search{query, screen_query, components, buffer, margin, guess, 0.0};
    search.best_squared = exact_squared(search, guess, std::numeric_limits<double>::infinity());
    search.screen_above = screen_limit(search.best_squared, margin);
    if (!(box_screen(0, search) > search.screen_above)) visit(0, search);
    return {search.best, std::sqrt(search.best_squared)};
  }

 private:
  struct Node {
    int begin = 0, end = 0;
    int right = -1;  // the left child is the next node; -1 for a leaf
  };
  struct Search {
    const double* query;
    const float* screen_query;
    const std::vector<int>& components;
    double* buffer;
    double margin;
    int best;
    double best_squared;
    float screen_above = 0.0F;
  };

  // The tree's shape depends on the number of points alone (splits at the median), so each
  // subtree's nodes have known places and the halves are built in parallel.
  static int node_count(int points) { return points <= kLeafSize ? 1 : 1 + node_count(points / 2) + node_count(points - points / 2); }

  float* screen_row(int p) const { return screen_.get() + static_cast<std::size_t>(p) * static_cast<std::size_t>(padded_); }

  // A box or row whose single-precision sum exceeds this has a double distance above
  // `best_squared`. The sum is within a factor 1 + sum_error_ of the exact distance of the
  // rounded values (plus underflows), which is within `margin` of the exact distance of the
  // double values (boxes hold the double rows: only the query moves), which is within
  // kDoubleSlack of the double distance that decides. A NaN (from a NaN query) passes
  // everything on to the double comparison.
  float screen_limit(double best_squared, double margin) const {
    const double reach = std::sqrt(best_squared) * (1.0 + kDoubleSlack) + margin;
    return float_above(reach * reach * (1.0 + sum_error_) + static_cast<double>(padded_) * kFloatTiny);
  }

  double exact_squared(const Search& search, int row, double limit) const {
    const double* point = source_row_(row, search.buffer);
    if (search.components.empty()) return squared_distance(search.query, point, k_, limit);
    double squared = 0.0;
    for (const int c : search.components) squared += (search.query[c] - point[c]) * (search.query[c] - point[c]);
    return squared;
  }

  // The single-precision squared distance from the query to the tree's p-th row; past the
  // search's limit, a partial sum above it.
  float row_screen(int p, const Search& search) const {
    const float* point = screen_row(p);
    if (search.components.empty()) return squared_distance_lanes(search.screen_query, point, padded_, search.screen_above);
    float squared = 0.0F;
    for (const int c : search.components) {
      const float d = search.screen_query[c] - point[c];
      squared += d * d;
    }
    return squared;
  }

  // The single-precision squared distance from the query to the node's box, likewise.
  float box_screen(int node, const Search& search) const {
    const auto offset = static_cast<std::size_t>(node) * static_cast<std::size_t>(padded_);
    const float* low = low_.data() + offset;
    const float* high = high_.data() + offset;
    if (search.components.empty()) return box_distance_lanes(search.screen_query, low, high, padded_, search.screen_above);
    float to_box = 0.0F;
    for (const int c : search.components) {
      const float q = search.screen_query[c];
      const float gap = std::max(low[c] - q, 0.0F) + std::max(q - high[c], 0.0F);
      to_box += gap * gap;
    }
    return to_box;
  }

  // Builds the subtree of `node` over the tree-order rows [begin, end) (`screen_` still in the
  // source's order): splits, children, and then the box, from the children's boxes.
  void build(int node, int begin, int end, std::vector<float>& projection) {
    auto row = [&](int p) { return Eigen::Map<const Eigen::RowVectorXf>(screen_row(index_[static_cast<std::size_t>(p)]), padded_); };
    nodes_[static_cast<std::size_t>(node)] = {begin, end, -1};
    float* low = low_.data() + static_cast<std::size_t>(node) * static_cast<std::size_t>(padded_);
    float* high = high_.data() + static_cast<std::size_t>(node) * static_cast<std::size_t>(padded_);
    if (end - begin <= kLeafSize) {
      // A float next below (above) a row's rounded value is below (above) its double value: the
      // box holds the double rows.
      for (int c = 0; c < k_; ++c) {
        float smallest = row(begin)(c), largest = smallest;
        for (int p = begin + 1; p < end; ++p) smallest = std::min(smallest, row(p)(c)), largest = std::max(largest, row(p)(c));
        low[c] = std::nextafter(smallest, -std::numeric_limits<float>::infinity());
        high[c] = std::nextafter(largest, std::numeric_limits<float>::infinity());
      }
      return;
    }
    // Split at the median along the sheet's long extent: the line from the row farthest from the
    // mean to the row farthest from that one, both found among at most kDirectionSample rows
    // spread over the node (a direction, not a bound: the search is exact whatever it is).
    const int step = std::max(1, (end - begin) / kDirectionSample);
    Eigen::RowVectorXf mean = Eigen::RowVectorXf::Zero(padded_);
    int sampled = 0;
    for (int p = begin; p < end; p += step, ++sampled) mean += row(p);
    mean /= static_cast<float>(sampled);
    auto farthest_from = [&](const Eigen::RowVectorXf& from) {
      int far = begin;
      float widest = -1.0F;
      for (int p = begin; p < end; p += step) {
        const float squared = (row(p) - from).squaredNorm();
        if (squared > widest) widest = squared, far = p;
      }
      return Eigen::RowVectorXf(row(far));
    };
    const Eigen::RowVectorXf from = farthest_from(mean);
    const Eigen::RowVectorXf direction = farthest_from(from) - from;
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
      build(left, begin, middle, projection);
      build(right, middle, end, projection);
    } else {
      tbb::parallel_invoke([&] { build(left, begin, middle, projection); }, [&] { build(right, middle, end, projection); });
    }
    const float* left_low = low_.data() + static_cast<std::size_t>(left) * static_cast<std::size_t>(padded_);
    const float* left_high = high_.data() + static_cast<std::size_t>(left) * static_cast<std::size_t>(padded_);
    const float* right_low = low_.data() + static_cast<std::size_t>(right) * static_cast<std::size_t>(padded_);
    const float* right_high = high_.data() + static_cast<std::size_t>(right) * static_cast<std::size_t>(padded_);
    for (int c = 0; c < k_; ++c) {
      low[c] = std::min(left_low[c], right_low[c]);
      high[c] = std::max(left_high[c], right_high[c]);
    }
  }

  void visit(int node, Search& search) const {
    const Node& here = nodes_[static_cast<std::size_t>(node)];
    if (here.right < 0) {
      for (int p = here.begin; p < here.end; ++p) {
        if (row_screen(p, search) > search.screen_above) continue;
        const int index = index_[static_cast<std::size_t>(p)];
        const double squared = exact_squared(search, index, search.best_squared);
        if (squared < search.best_squared || (squared == search.best_squared && index < search.best)) {
          search.best_squared = squared;
          search.best = index;
          search.screen_above = screen_limit(squared, search.margin);
        }
      }
      return;
    }
    const float left_bound = box_screen(node + 1, search);
    const float right_bound = box_screen(here.right, search);
    const bool right_first = right_bound < left_bound;
    const int first = right_first ? here.right : node + 1;
    const int second = right_first ? node + 1 : here.right;
    if (!((right_first ? right_bound : left_bound) > search.screen_above)) visit(first, search);
    if (!((right_first ? left_bound : right_bound) > search.screen_above)) visit(second, search);
  }

  int k_, padded_;
  const SourceRow& source_row_;
  std::vector<Node> nodes_;
  std::vector<float> low_, high_;    // per node, the box: `padded_` each, zeros after k
  std::vector<int> index_;           // tree order → source row
  std::unique_ptr<float[]> screen_;  // the rows in single precision, `padded_` each: in tree order once built
  double largest_norm_ = 0.0;
  double sum_error_ = 0.0;
};

// The matching of `target_count` queries, query t's k values given by query_row(t, buffer), of
// `source_count` source rows given by source_row(r, buffer) (buffers of row_buffer_length(k)).
template <class QueryRow, class SourceRow>
TriangleMatch match(Eigen::Index target_count, int k, const QueryRow& query_row, Eigen::Index source_count, const SourceRow& source_row,
                    int top_n) {
  if (top_n != 0 && (top_n < 3 || top_n > k)) {
    throw std::invalid_argument("top-n must be between 3 and the number of markers (" + std::to_string(k) + "), got " + std::to_string(top_n));
  }
  TriangleMatch match;
  match.source.assign(static_cast<std::size_t>(target_count), -1);
  match.distance.assign(static_cast<std::size_t>(target_count), 0.0);
  if (target_count == 0 || source_count == 0) return match;
  if (top_n == k) top_n = 0;

  const CoordinateTree<SourceRow> tree = [&] {
    const trace::Scope traced("search tree", "set-up");
    return CoordinateTree<SourceRow>(source_count, k, source_row);
  }();
  const trace::Scope traced("nearest source triangles", "set-up");
  // Neighbouring target triangles (mostly neighbours in the file's order, too) have nearby
  // matches: each query starts from the previous one's answer.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, target_count, 128), [&](const auto& range) {
    std::vector<int> components;
    std::vector<int> order(static_cast<std::size_t>(k));
    std::vector<double> query_buffer(row_buffer_length(k)), source_buffer(row_buffer_length(k));
    std::vector<float> screen_query(static_cast<std::size_t>(tree.padded()), 0.0F);
    int guess = 0;
    for (Eigen::Index t = range.begin(); t != range.end(); ++t) {
      const double* query = query_row(t, query_buffer.data());
      for (int c = 0; c < k; ++c) screen_query[static_cast<std::size_t>(c)] = static_cast<float>(query[c]);
      if (top_n > 0) {
        // The n largest components, ties to the lower index.
        std::iota(order.begin(), order.end(), 0);
        std::partial_sort(order.begin(), order.begin() + top_n, order.end(),
                          [&](int a, int b) { return query[a] > query[b] || (query[a] == query[b] && a < b); });
        components.assign(order.begin(), order.begin() + top_n);
        std::sort(components.begin(), components.end());
      }
      const auto [nearest, distance] = tree.nearest(query, screen_query.data(), components, guess, source_buffer.data());
      match.source[static_cast<std::size_t>(t)] = nearest;
      match.distance[static_cast<std::size_t>(t)] = distance;
      guess = nearest;
    }
  });
  return match;
}

// Rows of a written matrix, and triangles' rows from their corners'.
auto written_rows(const CoordinateRows& rows) {
  return [&rows](Eigen::Index r, double*) { return rows.row(r).data(); };
}
auto triangle_rows(const VertexCoordinates& coordinates, const Eigen::MatrixXi& triangles) {
  return [&coordinates, &triangles](Eigen::Index t, double* buffer) {
    const int k = coordinates.columns();
    coordinates.triangle_row(triangles, t, buffer, buffer + k);
    return static_cast<const double*>(buffer);
  };
}

}  // namespace

TriangleMatch match_triangles(const CoordinateRows& target, const CoordinateRows& source, int top_n) {
  const auto k = static_cast<int>(source.cols());
  if (target.cols() != k) throw std::invalid_argument("match_triangles: target and source coordinates differ in length");
  return match(target.rows(), k, written_rows(target), source.rows(), written_rows(source), top_n);
}

TriangleMatch match_triangles(const VertexCoordinates& target, const Eigen::MatrixXi& target_triangles, const VertexCoordinates& source,
                              const Eigen::MatrixXi& source_triangles, int top_n) {
  const int k = target.columns();
  if (source.columns() != k) throw std::invalid_argument("match_triangles: target and source coordinates differ in length");
  return match(target_triangles.rows(), k, triangle_rows(target, target_triangles), source_triangles.rows(),
               triangle_rows(source, source_triangles), top_n);
}

}  // namespace hdeform

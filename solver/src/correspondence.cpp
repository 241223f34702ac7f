#include "hdeform/correspondence.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>

#include <nanoflann.hpp>
#include <tbb/parallel_for.h>

namespace hdeform {
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Rows of a row-major matrix as nanoflann's points.
struct RowPoints {
  const RowMajor& rows;
  std::size_t kdtree_get_point_count() const { return static_cast<std::size_t>(rows.rows()); }
  double kdtree_get_pt(std::size_t index, std::size_t dimension) const {
    return rows(static_cast<Eigen::Index>(index), static_cast<Eigen::Index>(dimension));
  }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, RowPoints>, RowPoints, -1, std::uint32_t>;
constexpr std::size_t kLeafSize = 16;

// Nearest `points` row to each of `queries`' rows; writes match.source/distance at `targets`.
void match_rows(const RowMajor& points, const RowMajor& queries, const std::vector<int>& targets, TriangleMatch& match) {
  const RowPoints adaptor{points};
  const Tree tree(static_cast<int>(points.cols()), adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, targets.size(), 64), [&](const auto& range) {
    for (std::size_t q = range.begin(); q != range.end(); ++q) {
      std::uint32_t nearest = 0;
      double squared = 0.0;
      nanoflann::KNNResultSet<double, std::uint32_t> result(1);
      result.init(&nearest, &squared);
      tree.findNeighbors(result, queries.row(static_cast<Eigen::Index>(q)).data(), nanoflann::SearchParams());
      const auto t = static_cast<std::size_t>(targets[q]);
      match.source[t] = static_cast<int>(nearest);
      match.distance[t] = std::sqrt(squared);
    }
  });
}

}  // namespace

TriangleMatch match_triangles(const Eigen::MatrixXd& target, const Eigen::MatrixXd& source, int top_n) {
  const auto k = static_cast<int>(source.cols());
  if (target.cols() != k) throw std::invalid_argument("match_triangles: target and source coordinates differ in length");
  if (top_n != 0 && (top_n < 3 || top_n > k)) {
    throw std::invalid_argument("top-n must be between 3 and the number of markers (" + std::to_string(k) + "), got " + std::to_string(top_n));
  }
  TriangleMatch match;
  const auto target_count = static_cast<std::size_t>(target.rows());
  match.source.assign(target_count, -1);
  match.distance.assign(target_count, 0.0);
  if (target_count == 0 || source.rows() == 0) return match;

  if (top_n == 0 || top_n == k) {
    const RowMajor points = source;
    const RowMajor queries = target;
    std::vector<int> all(target_count);
    std::iota(all.begin(), all.end(), 0);
    match_rows(points, queries, all, match);
    return match;
  }

  // Group the target triangles by their n largest components (ties to the lower index): each
  // group searches the source coordinates projected onto its components.
  std::map<std::vector<int>, std::vector<int>> groups;
  std::vector<int> order(static_cast<std::size_t>(k));
  for (std::size_t t = 0; t < target_count; ++t) {
    std::iota(order.begin(), order.end(), 0);
    const auto row = target.row(static_cast<Eigen::Index>(t));
    std::partial_sort(order.begin(), order.begin() + top_n, order.end(), [&](int a, int b) { return row(a) > row(b) || (row(a) == row(b) && a < b); });
    std::vector<int> components(order.begin(), order.begin() + top_n);
    std::sort(components.begin(), components.end());
    groups[components].push_back(static_cast<int>(t));
  }
  const std::vector<std::pair<std::vector<int>, std::vector<int>>> work(groups.begin(), groups.end());
  tbb::parallel_for(std::size_t{0}, work.size(), [&](std::size_t g) {
    const auto& [components, members] = work[g];
    RowMajor points(source.rows(), top_n);
    RowMajor queries(static_cast<Eigen::Index>(members.size()), top_n);
    for (int c = 0; c < top_n; ++c) {
      points.col(c) = source.col(components[static_cast<std::size_t>(c)]);
      for (std::size_t q = 0; q < members.size(); ++q) queries(static_cast<Eigen::Index>(q), c) = target(members[q], components[static_cast<std::size_t>(c)]);
    }
    match_rows(points, queries, members, match);
  });
  return match;
}

}  // namespace hdeform

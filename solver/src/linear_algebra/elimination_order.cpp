// Fill-reducing elimination orders: Eigen's AMD, and METIS's nested dissection.
#include <metis.h>

#include <Eigen/OrderingMethods>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "hdeform/sparse_cholesky.h"
#include "hdeform/trace.h"

namespace hdeform {
namespace {

std::vector<int> minimum_degree_ranks(const Eigen::SparseMatrix<double>& matrix) {
  Eigen::AMDOrdering<int> ordering;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> elimination_order;
  ordering(matrix, elimination_order);  // step k eliminates unknown elimination_order[k]
  std::vector<int> rank(static_cast<std::size_t>(matrix.rows()));
  for (Eigen::Index k = 0; k < matrix.rows(); ++k) rank[static_cast<std::size_t>(elimination_order.indices()[k])] = static_cast<int>(k);
  return rank;
}

std::vector<int> nested_dissection_ranks(const Eigen::SparseMatrix<double>& matrix) {
  static_assert(std::is_same_v<idx_t, int>, "METIS with 32-bit indices (Debian's) fills the ranks in place");
  idx_t n = static_cast<idx_t>(matrix.rows());
  std::vector<int> rank(static_cast<std::size_t>(n));
  // METIS's graph: each unknown's neighbours, without itself. The matrix is column-major with
  // both triangles, so column j lists j's neighbours.
  std::vector<idx_t> first(static_cast<std::size_t>(n) + 1, 0);
  std::vector<idx_t> neighbours;
  neighbours.reserve(static_cast<std::size_t>(matrix.nonZeros()));
  for (idx_t j = 0; j < n; ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator entry(matrix, j); entry; ++entry) {
      if (entry.row() != j) neighbours.push_back(static_cast<idx_t>(entry.row()));
    }
    first[static_cast<std::size_t>(j) + 1] = static_cast<idx_t>(neighbours.size());
  }
  if (neighbours.empty()) {  // no fill whatever the order (METIS wants edges)
    std::iota(rank.begin(), rank.end(), 0);
    return rank;
  }
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_NUMBERING] = 0;
  // METIS seeds the C library's rand() with this and draws from it: the same order every time
  // (hdeform itself never calls rand()).
  options[METIS_OPTION_SEED] = 1;
  // METIS gives the order (the unknown eliminated at each step) and its inverse, the ranks.
  std::vector<idx_t> order(static_cast<std::size_t>(n));
  // One call at a time: each draws from the process's one rand() (two at once would interleave
  // their draws, and the orders would depend on timing), and each installs METIS's handler for
  // SIGTERM and SIGABRT and puts back the one it found, so two overlapping calls could leave
  // METIS's in place for good.
  static std::mutex one_at_a_time;
  const std::lock_guard lock(one_at_a_time);
  const int status = METIS_NodeND(&n, first.data(), neighbours.data(), nullptr, options, order.data(), rank.data());
  if (status == METIS_ERROR_MEMORY) throw std::bad_alloc();
  if (status != METIS_OK) throw std::runtime_error("METIS nested dissection failed (status " + std::to_string(status) + ")");
  return rank;
}

}  // namespace

std::string_view to_string(EliminationOrder order) {
  switch (order) {
    case EliminationOrder::Automatic: return "automatic";
    case EliminationOrder::MinimumDegree: return "minimum degree";
    case EliminationOrder::NestedDissection: return "nested dissection";
  }
  return "?";
}

EliminationOrder elimination_order_for(Eigen::Index unknowns) {
  return unknowns >= kNestedDissectionFrom ? EliminationOrder::NestedDissection : EliminationOrder::MinimumDegree;
}

std::vector<int> elimination_ranks(const Eigen::SparseMatrix<double>& matrix, EliminationOrder order) {
  if (matrix.rows() != matrix.cols()) throw std::invalid_argument("elimination_ranks: the matrix is not square");
  if (order == EliminationOrder::Automatic) order = elimination_order_for(matrix.rows());
  if (order == EliminationOrder::NestedDissection) {
    const trace::Scope traced("elimination order (nested dissection)", "set-up");
    return nested_dissection_ranks(matrix);
  }
  const trace::Scope traced("elimination order (AMD)", "set-up");
  return minimum_degree_ranks(matrix);
}

}  // namespace hdeform

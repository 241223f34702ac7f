#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <vector>
#include <numeric>
#include <optional>
#include <string>
#include <unistd.h>
#include <stdexcept>

#include "hdeform/constraints.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/errors.h"
#include "hdeform/laplacian.h"
#include "hdeform/shapes.h"
#include "hdeform/sparse_cholesky.h"
#include "test_support.h"
#include "linear_algebra/factor_memory.h"
#include "linear_algebra/tree_factorization.h"

namespace hdeform {
namespace {

// A symmetric positive definite test matrix: a Laplacian with a few Dirichlet vertices removed.
Eigen::SparseMatrix<double> spd_matrix(const Mesh& mesh) {
  const auto laplacian = cotangent_laplacian(mesh);
  const auto n = mesh.vertex_count();
  // Shift by a diagonal so that no row is removed but the matrix is definite.
  Eigen::SparseMatrix<double> identity(n, n);
  identity.setIdentity();
  return laplacian + 1e-3 * identity;
}

TEST(SparseCholesky, MatchesADenseSolve) {
  const auto matrix = spd_matrix(make_shape(ShapeKind::Cactus, 12).mesh);
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 5, 3);
  const Eigen::MatrixXd expected = Eigen::MatrixXd(matrix).ldlt().solve(rhs);
  for (const auto backend : test::available_backends()) {
    SparseCholesky factor;
    factor.factor(matrix, backend);
    EXPECT_LE(test::relative_difference(factor.solve(rhs), expected), 1e-10) << to_string(backend);
    // More columns than one kernel pass takes (8): solved in chunks, same answer.
    const Eigen::MatrixXd wide_rhs = test::random_matrix(matrix.rows(), 19, 4);
    const Eigen::MatrixXd wide_expected = Eigen::MatrixXd(matrix).ldlt().solve(wide_rhs);
    EXPECT_LE(test::relative_difference(factor.solve(wide_rhs), wide_expected), 1e-10) << to_string(backend);
  }
}

TEST(SparseCholesky, BackendsAgree) {
  if (test::available_backends().size() < 2) GTEST_SKIP() << "this build has only the Eigen backend";
  const Mesh mesh = make_shape(ShapeKind::Cactus, 32).mesh;
  const auto matrix = spd_matrix(mesh);
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 3, 5);
  SparseCholesky eigen, cholmod;
  eigen.factor(matrix, SolverBackend::Eigen);
  cholmod.factor(matrix, SolverBackend::Cholmod);
  const Eigen::MatrixXd a = eigen.solve(rhs), b = cholmod.solve(rhs);
  EXPECT_LE((a - b).norm() / a.norm(), 1e-10);
  EXPECT_GT((a - b).norm(), 0.0);  // different orderings: really two computations
}

TEST(SparseCholesky, RejectsAnIndefiniteMatrix) {
  const auto laplacian = cotangent_laplacian(make_shape(ShapeKind::Sphere, 8).mesh);  // singular: constants
  Eigen::SparseMatrix<double> indefinite = -laplacian;
  // Small ones whose last pivot is the bad one: negative, zero, and negative only after an update.
  auto dense = [](std::initializer_list<double> values, int n) {
    Eigen::MatrixXd matrix(n, n);
    auto it = values.begin();
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) matrix(i, j) = *it++;
    }
    return Eigen::SparseMatrix<double>(matrix.sparseView());
  };
  Eigen::SparseMatrix<double> zero(1, 1);
  zero.insert(0, 0) = 0.0;
  for (const auto& matrix : {indefinite, dense({-1.0}, 1), zero, dense({1.0, 2.0, 2.0, 1.0}, 2)}) {
    for (const auto backend : test::available_backends()) {
      SparseCholesky factor;
      EXPECT_THROW(factor.factor(matrix, backend), SolveError) << to_string(backend) << ", " << matrix.rows() << " unknowns";
    }
  }
}

// The elimination-tree factorization on a matrix large enough to be split over threads.
Eigen::SparseMatrix<double> split_matrix() {
  const auto matrix = spd_matrix(make_shape(ShapeKind::Cactus, 48).mesh);
  EXPECT_GE(matrix.rows(), 4000);
  return matrix;
}

Eigen::MatrixXd solve_in_arena(const Eigen::SparseMatrix<double>& matrix, const Eigen::MatrixXd& rhs, int threads,
                               std::size_t* subtrees = nullptr) {
  tbb::task_arena arena(threads);
  return arena.execute([&] {
    SparseCholesky factor;
    factor.factor(matrix, SolverBackend::Tree);
    if (subtrees != nullptr) *subtrees = factor.subtree_count();
    return factor.solve(rhs);
  });
}

TEST(TreeFactorization, IsBitIdenticalOnAnyNumberOfThreads) {
  const auto matrix = split_matrix();
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 3, 11);
  std::size_t one_subtrees = 0, two_subtrees = 0, three_subtrees = 0;
  const Eigen::MatrixXd one = solve_in_arena(matrix, rhs, 1, &one_subtrees);
  const Eigen::MatrixXd two = solve_in_arena(matrix, rhs, 2, &two_subtrees);
  const Eigen::MatrixXd three = solve_in_arena(matrix, rhs, 3, &three_subtrees);
  EXPECT_EQ(one_subtrees, 0u);  // sequential: every row in the top part
  EXPECT_EQ(two_subtrees, 2u);
  EXPECT_EQ(three_subtrees, 3u);
  EXPECT_EQ(one, two);
  EXPECT_EQ(one, three);
}

// solve_block at any stride: the plain gathers and the four-lane ones (three or four columns four
// doubles apart, five to eight eight apart) sum in one order, so every stride gives the bits of
// the packed block, on one thread and on two; the pad is read but never written (a NaN there
// stays, and reaches no column).
TEST(TreeFactorization, EveryStrideGivesTheSameBitsAndLeavesThePadAlone) {
  const auto matrix = split_matrix();
  const auto n = matrix.rows();
  // (11, 13, 19: a last kernel of three, five or three columns, in lanes where the row has room.)
  for (const int columns : {1, 2, 3, 4, 5, 7, 8, 9, 11, 13, 19}) {
    const Eigen::MatrixXd rhs = test::random_matrix(n, columns, 20 + columns);
    for (const int threads : {1, 2}) {
      tbb::task_arena arena(threads);
      arena.execute([&] {
        SparseCholesky factor;
        factor.factor(matrix, SolverBackend::Tree);
        auto solve_at = [&](int stride) {
          std::vector<double> block(static_cast<std::size_t>(n * stride), std::numeric_limits<double>::quiet_NaN());
          for (Eigen::Index i = 0; i < n; ++i) {
            for (int c = 0; c < columns; ++c) block[static_cast<std::size_t>(factor.factor_row()[static_cast<std::size_t>(i)] * stride + c)] = rhs(i, c);
          }
          factor.solve_block(block.data(), columns, stride);
          Eigen::MatrixXd solution(n, columns);
          for (Eigen::Index i = 0; i < n; ++i) {
            const auto row = static_cast<std::size_t>(factor.factor_row()[static_cast<std::size_t>(i)] * stride);
            for (int c = 0; c < columns; ++c) solution(i, c) = block[row + static_cast<std::size_t>(c)];
            for (int pad = columns; pad < stride; ++pad) EXPECT_TRUE(std::isnan(block[row + static_cast<std::size_t>(pad)])) << columns << " " << stride;
          }
          return solution;
        };
        const Eigen::MatrixXd packed = solve_at(columns);
        EXPECT_LE((matrix * packed - rhs).norm(), 1e-10 * rhs.norm()) << columns;
        for (const int stride : {SparseCholesky::fast_solve_stride(columns), columns + 1, 4, 8, 11, 16, 24}) {
          if (stride < columns) continue;
          EXPECT_EQ(solve_at(stride), packed) << columns << " columns at stride " << stride << ", " << threads << " threads";
        }
      });
    }
  }
  EXPECT_EQ(SparseCholesky::fast_solve_stride(3), 4);
  EXPECT_EQ(SparseCholesky::fast_solve_stride(5), 8);
  EXPECT_EQ(SparseCholesky::fast_solve_stride(11), 12);
  EXPECT_EQ(SparseCholesky::fast_solve_stride(13), 16);
  EXPECT_EQ(SparseCholesky::fast_solve_stride(55), 56);
  for (const int unpadded : {1, 2, 4, 8, 9, 10, 12, 124}) EXPECT_EQ(SparseCholesky::fast_solve_stride(unpadded), unpadded);
}

// The top's chains, checked against the tree itself: they partition the top, each climbs from
// node to parent, a chain starts where the top branches or ends, its parent chain is the one that
// holds its last node's parent, and its work is that of every top node at or below its last.
void expect_top_chains_follow_the_tree(std::span<const int> parent, std::span<const double> work, const detail::EliminationSchedule& schedule) {
  const detail::TopChains& chains = schedule.top_chains;
  std::vector<int> in_top(parent.size(), 0), chain_of(parent.size(), -1), top_children(parent.size(), 0);
  for (const int node : schedule.top) in_top[static_cast<std::size_t>(node)] = 1;
  for (const int node : schedule.top) {
    if (parent[static_cast<std::size_t>(node)] >= 0) ++top_children[static_cast<std::size_t>(parent[static_cast<std::size_t>(node)])];
  }
  std::size_t covered = 0;
  for (int c = 0; c < chains.count(); ++c) {
    const auto nodes = chains.nodes_of(c);
    ASSERT_FALSE(nodes.empty());
    EXPECT_NE(top_children[static_cast<std::size_t>(nodes.front())], 1) << "chain " << c << " starts inside a run";
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const auto node = static_cast<std::size_t>(nodes[i]);
      EXPECT_EQ(in_top[node], 1);
      EXPECT_EQ(chain_of[node], -1) << "node " << node << " in two chains";
      chain_of[node] = c;
      if (i + 1 < nodes.size()) {
        EXPECT_EQ(parent[node], nodes[i + 1]);
        EXPECT_EQ(top_children[static_cast<std::size_t>(nodes[i + 1])], 1);
      }
    }
    covered += nodes.size();
  }
  EXPECT_EQ(covered, schedule.top.size());
  std::size_t roots = 0;
  for (int c = 0; c < chains.count(); ++c) {
    const int last = chains.nodes_of(c).back();
    const int up = parent[static_cast<std::size_t>(last)];
    if (up < 0) {
      ++roots;
      EXPECT_NE(std::find(chains.roots.begin(), chains.roots.end(), c), chains.roots.end());
    } else {
      const auto siblings = chains.children_of(chain_of[static_cast<std::size_t>(up)]);
      EXPECT_NE(std::find(siblings.begin(), siblings.end(), c), siblings.end()) << "chain " << c << " is not its parent's child";
    }
    double below = 0.0;  // every top node at or below the chain's last node
    for (const int node : schedule.top) {
      int at = node;
      while (at >= 0 && at < last) at = parent[static_cast<std::size_t>(at)];
      if (at == last) below += work[static_cast<std::size_t>(node)];
    }
    EXPECT_NEAR(chains.work[static_cast<std::size_t>(c)], below, 1e-9 * below);
  }
  EXPECT_EQ(roots, chains.roots.size());
  std::size_t children = 0;
  for (int c = 0; c < chains.count(); ++c) children += chains.children_of(c).size();
  EXPECT_EQ(children + roots, static_cast<std::size_t>(chains.count()));
}

// A split of a tree: the top and the subtrees partition the nodes, each list ascending; the top is
// closed under ancestors and each worker's nodes under descendants (a node's parent is in its
// worker's list or in the top). Returns the span: the top's work plus the busiest worker's.
double expect_a_split_of_the_tree(std::span<const int> parent, std::span<const double> work, const detail::EliminationSchedule& schedule) {
  std::vector<int> owner(parent.size(), -2);  // −1: the top
  auto claim = [&](const std::vector<int>& nodes, int who) {
    EXPECT_TRUE(std::is_sorted(nodes.begin(), nodes.end()));
    for (const int node : nodes) {
      EXPECT_EQ(owner[static_cast<std::size_t>(node)], -2) << "node " << node << " listed twice";
      owner[static_cast<std::size_t>(node)] = who;
    }
  };
  claim(schedule.top, -1);
  for (std::size_t part = 0; part < schedule.subtrees.size(); ++part) claim(schedule.subtrees[part], static_cast<int>(part));
  double top = 0.0;
  std::vector<double> load(schedule.subtrees.size(), 0.0);
  for (std::size_t node = 0; node < parent.size(); ++node) {
    EXPECT_NE(owner[node], -2) << "node " << node << " in no list";
    const int up = parent[node];
    const int up_owner = up < 0 ? -1 : owner[static_cast<std::size_t>(up)];
    if (owner[node] == -1) {
      top += work[node];
      EXPECT_EQ(up_owner, -1) << "top node " << node << " below a subtree's node";
    } else if (owner[node] >= 0) {
      load[static_cast<std::size_t>(owner[node])] += work[node];
      EXPECT_TRUE(up_owner == -1 || up_owner == owner[node]) << "node " << node << " and its parent on two workers";
    }
  }
  return top + (load.empty() ? 0.0 : *std::max_element(load.begin(), load.end()));
}

TEST(EliminationSchedule, TheTopsChainsFollowTheTree) {
  const auto matrix = split_matrix();
  const auto permuted = detail::permuted_matrix(matrix, elimination_ranks(matrix));
  detail::FactorPattern pattern = detail::analyse_pattern(permuted, 2);
  std::vector<double> column_work(static_cast<std::size_t>(pattern.size())), sweep_work(column_work.size());
  for (int j = 0; j < pattern.size(); ++j) {
    column_work[static_cast<std::size_t>(j)] = static_cast<double>(pattern.column_length(j));
    sweep_work[static_cast<std::size_t>(j)] = column_work[static_cast<std::size_t>(j)] + (pattern.row_start[static_cast<std::size_t>(j) + 1] - pattern.row_start[static_cast<std::size_t>(j)]);
  }
  for (const int parts : {1, 2, 3, 8}) {
    SCOPED_TRACE(parts);
    const auto schedule = detail::split_elimination_tree(pattern.parent, column_work, parts);
    expect_a_split_of_the_tree(pattern.parent, column_work, schedule);
    expect_top_chains_follow_the_tree(pattern.parent, column_work, schedule);
    detail::schedule_sweeps(pattern, parts);
    EXPECT_EQ(pattern.schedule.subtrees.size(), parts > 1 ? static_cast<std::size_t>(parts) : 0u);
    expect_a_split_of_the_tree(pattern.parent, sweep_work, pattern.schedule);
    expect_top_chains_follow_the_tree(pattern.parent, sweep_work, pattern.schedule);
    if (parts > 2) {
      // A top that branches, so that the solves' tests on three threads run sibling chains side
      // by side (on two, the least span keeps one chain of the root's separators).
      const auto& chains = pattern.schedule.top_chains;
      EXPECT_GT(chains.count(), 2);
      EXPECT_TRUE(std::any_of(chains.child_start.begin(), chains.child_start.end() - 1,
                              [&, c = 0](int) mutable { return chains.children_of(c++).size() >= 2; }));
    }
  }
  // A forest: two separate paths and a lone node, all in the top.
  const std::vector<int> forest{1, 2, -1, 4, -1, -1};
  const std::vector<double> ones(forest.size(), 1.0);
  const auto schedule = detail::split_elimination_tree(forest, ones, 1);
  expect_top_chains_follow_the_tree(forest, ones, schedule);
  EXPECT_EQ(schedule.top_chains.count(), 3);
  EXPECT_EQ(schedule.top_chains.roots.size(), 3u);
}

// Appends a path of `length` nodes of work 1 (each the parent of the one before it) and returns
// its last node; `below`, when given, becomes the child of its first node.
int append_path(std::vector<int>& parent, int length, std::vector<int> below = {}) {
  const int first = static_cast<int>(parent.size());
  for (int k = 0; k < length; ++k) parent.push_back(-1);
  for (int k = 0; k + 1 < length; ++k) parent[static_cast<std::size_t>(first + k)] = first + k + 1;
  for (const int child : below) parent[static_cast<std::size_t>(child)] = first;
  return first + length - 1;
}

// The sweeps' split against spans worked out by hand: a root path of 24 nodes over three paths of
// 500, 300 and 250 nodes (every node of work 1). On two workers the least span is the root path
// on one thread, then the 500 beside the 300 and the 250: 24 + 550. On three, 24 + 500. The even
// packing's top (every subtree down to a sixteenth of a share) is far from it.
TEST(EliminationSchedule, TheSweepsSplitHasTheLeastSpan) {
  std::vector<int> parent;
  const int a = append_path(parent, 500), b = append_path(parent, 300), c = append_path(parent, 250);
  append_path(parent, 24, {a, b, c});
  const std::vector<double> ones(parent.size(), 1.0);
  const auto two = detail::split_elimination_tree(parent, ones, 2, detail::SplitGoal::LeastSpan);
  EXPECT_EQ(expect_a_split_of_the_tree(parent, ones, two), 574.0);
  EXPECT_EQ(two.top.size(), 24u);
  const auto three = detail::split_elimination_tree(parent, ones, 3, detail::SplitGoal::LeastSpan);
  EXPECT_EQ(expect_a_split_of_the_tree(parent, ones, three), 524.0);
  const auto even = detail::split_elimination_tree(parent, ones, 2);
  EXPECT_GT(expect_a_split_of_the_tree(parent, ones, even), 574.0 + 100.0);

  // A second copy beside it, a forest of two trees of 1,074 nodes: on two workers, a tree each and
  // no top.
  const auto offset = static_cast<int>(parent.size());
  for (std::size_t node = 0; node < static_cast<std::size_t>(offset); ++node) parent.push_back(parent[node] < 0 ? -1 : parent[node] + offset);
  const std::vector<double> forest_ones(parent.size(), 1.0);
  const auto forest = detail::split_elimination_tree(parent, forest_ones, 2, detail::SplitGoal::LeastSpan);
  EXPECT_EQ(expect_a_split_of_the_tree(parent, forest_ones, forest), 1074.0);
  EXPECT_TRUE(forest.top.empty());
  // Not worth splitting at all: one worker, or a tree too small.
  EXPECT_TRUE(detail::split_elimination_tree(parent, forest_ones, 1, detail::SplitGoal::LeastSpan).subtrees.empty());
  const std::vector<int> small{2, 2, -1};
  EXPECT_EQ(detail::split_elimination_tree(small, std::vector<double>(3, 1.0), 2, detail::SplitGoal::LeastSpan).top.size(), 3u);
}

// On a mesh's factor (the cactus) the sweeps' split leaves a span no longer than the even
// packing's, and between an even share of the work and all of it.
TEST(EliminationSchedule, TheSweepsSplitBeatsTheEvenPackingOnAMesh) {
  const auto matrix = split_matrix();
  const auto permuted = detail::permuted_matrix(matrix, elimination_ranks(matrix));
  detail::FactorPattern pattern = detail::analyse_pattern(permuted, 2);
  std::vector<double> work(static_cast<std::size_t>(pattern.size()));
  for (int j = 0; j < pattern.size(); ++j) {
    work[static_cast<std::size_t>(j)] = static_cast<double>(pattern.column_length(j) + (pattern.row_start[static_cast<std::size_t>(j) + 1] - pattern.row_start[static_cast<std::size_t>(j)]));
  }
  const double total = std::accumulate(work.begin(), work.end(), 0.0);
  for (const int parts : {2, 3, 8}) {
    SCOPED_TRACE(parts);
    const double least = expect_a_split_of_the_tree(pattern.parent, work, detail::split_elimination_tree(pattern.parent, work, parts, detail::SplitGoal::LeastSpan));
    const double even = expect_a_split_of_the_tree(pattern.parent, work, detail::split_elimination_tree(pattern.parent, work, parts));
    EXPECT_LE(least, even);
    EXPECT_LT(least, total);
    EXPECT_GE(least, total / parts);
  }
}

// Many columns (harmonic coordinates: one per marker) are solved as whole solves side by side,
// a run of eight-column kernels per thread; each column comes out as a solve of its own kernel
// alone gives it, bit for bit, on any number of threads.
TEST(TreeFactorization, ManyColumnsSideBySideGiveEachKernelsOwnSolve) {
  const auto matrix = split_matrix();
  const int columns = 44;  // five full kernels and one of four
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), columns, 17);
  for (const int threads : {2, 3}) {
    tbb::task_arena arena(threads);
    arena.execute([&] {
      SparseCholesky factor;
      factor.factor(matrix, SolverBackend::Tree);
      const Eigen::MatrixXd together = factor.solve(rhs);
      for (int first = 0; first < columns; first += 8) {
        const int width = std::min(8, columns - first);
        EXPECT_EQ(together.middleCols(first, width), factor.solve(rhs.middleCols(first, width))) << "columns from " << first << ", " << threads << " threads";
      }
      EXPECT_LE((matrix * together - rhs).norm() / rhs.norm(), 1e-10);
    });
  }
}

TEST(TreeFactorization, AgreesWithSequentialEigenAndADenseSolve) {
  const auto matrix = split_matrix();
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 2, 12);
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> reference(matrix);
  ASSERT_EQ(reference.info(), Eigen::Success);
  const Eigen::MatrixXd expected = reference.solve(rhs);
  const Eigen::MatrixXd tree = solve_in_arena(matrix, rhs, 2);
  EXPECT_LE(test::relative_difference(tree, expected), 1e-12);
  EXPECT_GT((tree - expected).norm(), 0.0);  // summed in another order: really two computations
  // The residual of the factor itself, against the matrix.
  EXPECT_LE((matrix * tree - rhs).norm() / rhs.norm(), 1e-10);
}

// A grid's Laplacian (shifted to be definite) whose every 30th vertex is also joined to every
// other such vertex: the clique is eliminated last, so the top of the elimination tree is one
// wide dense supernode updated by wide separators, which takes the blocked paths of the
// factorization that a surface mesh of this size would not reach. `pivot` is added to the
// diagonal of one clique vertex.
Eigen::SparseMatrix<double> matrix_with_a_dense_top(double pivot = 0.0) {
  constexpr int side = 72, step = 30;
  const int n = side * side;
  std::vector<Eigen::Triplet<double>> entries;
  auto join = [&](int a, int b, double weight) {
    entries.emplace_back(a, b, -weight);
    entries.emplace_back(b, a, -weight);
    entries.emplace_back(a, a, weight);
    entries.emplace_back(b, b, weight);
  };
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const int v = y * side + x;
      if (x + 1 < side) join(v, v + 1, 1.0 + 0.1 * ((v * 7) % 5));
      if (y + 1 < side) join(v, v + side, 1.0 + 0.1 * ((v * 3) % 4));
      entries.emplace_back(v, v, 1e-2);
    }
  }
  for (int a = 0; a < n; a += step) {
    for (int b = a + step; b < n; b += step) join(a, b, 1e-2);
  }
  entries.emplace_back(step * 40, step * 40, pivot);
  Eigen::SparseMatrix<double> matrix(n, n);
  matrix.setFromTriplets(entries.begin(), entries.end());
  return matrix;
}

// The supernodal analysis and factorization against Eigen's simplicial LLᵀ of the same permuted
// matrix, entry by entry in both layouts: the same pattern, and the same values to rounding.
TEST(TreeFactorization, SupernodesGiveTheSimplicialFactorEntryByEntry) {
  for (const auto& matrix : {matrix_with_a_dense_top(), split_matrix()}) {
    SparseCholesky tree;
    tree.factor(matrix, SolverBackend::Tree);
    const auto& factor_row = tree.factor_row();
    const auto n = matrix.rows();
    std::vector<Eigen::Triplet<double>> permuted_entries;
    for (int c = 0; c < matrix.outerSize(); ++c) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(matrix, c); it; ++it) {
        permuted_entries.emplace_back(factor_row[static_cast<std::size_t>(it.row())], factor_row[static_cast<std::size_t>(c)], it.value());
      }
    }
    Eigen::SparseMatrix<double> permuted(n, n);
    permuted.setFromTriplets(permuted_entries.begin(), permuted_entries.end());
    const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> reference(permuted);
    ASSERT_EQ(reference.info(), Eigen::Success);
    const Eigen::SparseMatrix<double> lower = reference.matrixL();
    const Eigen::SparseMatrix<double, Eigen::RowMajor> by_rows = lower;
    const double largest = lower.coeffs().cwiseAbs().maxCoeff();

    const detail::PermutedMatrix ours = detail::permuted_matrix(matrix, factor_row);
    const detail::FactorPattern pattern = detail::analyse_pattern(ours, 2);
    detail::UninitializedVector<double> row_value, column_value;
    ASSERT_TRUE(detail::factor_numeric(ours, pattern, row_value, column_value));
    ASSERT_EQ(pattern.nonzeros(), static_cast<std::size_t>(lower.nonZeros()));
    double column_error = 0.0, row_error = 0.0;
    for (int j = 0; j < n; ++j) {
      ASSERT_EQ(pattern.column_length(j), static_cast<std::size_t>(lower.outerIndexPtr()[j + 1] - lower.outerIndexPtr()[j])) << "column " << j;
      for (int p = lower.outerIndexPtr()[j], q = 0; p < lower.outerIndexPtr()[j + 1]; ++p, ++q) {
        const std::size_t at = pattern.column_begin[static_cast<std::size_t>(j)] + static_cast<std::size_t>(q);
        ASSERT_EQ(pattern.column_rows(j)[q], lower.innerIndexPtr()[p]) << "column " << j;
        column_error = std::max(column_error, std::abs(column_value[at] - lower.valuePtr()[p]));
      }
      ASSERT_EQ(pattern.row_start[static_cast<std::size_t>(j) + 1] - pattern.row_start[static_cast<std::size_t>(j)], by_rows.outerIndexPtr()[j + 1] - by_rows.outerIndexPtr()[j]);
      for (int p = by_rows.outerIndexPtr()[j], at = pattern.row_start[static_cast<std::size_t>(j)]; p < by_rows.outerIndexPtr()[j + 1]; ++p, ++at) {
        ASSERT_EQ(pattern.row_column[static_cast<std::size_t>(at)], by_rows.innerIndexPtr()[p]) << "row " << j;
        row_error = std::max(row_error, std::abs(row_value[static_cast<std::size_t>(at)] - by_rows.valuePtr()[p]));
      }
    }
    EXPECT_LE(column_error, 1e-13 * largest);
    EXPECT_LE(row_error, 1e-13 * largest);
  }

  // The dense top really took the blocked paths, and the cactus the plain ones.
  const detail::PermutedMatrix dense = detail::permuted_matrix(matrix_with_a_dense_top(), [] {
    SparseCholesky tree;
    tree.factor(matrix_with_a_dense_top(), SolverBackend::Tree);
    return tree.factor_row();
  }());
  const detail::Supernodes& super = detail::analyse_pattern(dense, 2).supernodes;
  int widest = 0;
  long largest_update = 0;
  for (int s = 0; s < super.count(); ++s) widest = std::max(widest, super.width(s));
  const detail::FactorPattern dense_pattern = detail::analyse_pattern(dense, 2);
  for (const auto& update : dense_pattern.supernodes.updates) {
    const int from = update.from;
    const long length = static_cast<long>(dense_pattern.column_length(dense_pattern.supernodes.first_column[static_cast<std::size_t>(from)])) - update.first;
    largest_update = std::max(largest_update, static_cast<long>(dense_pattern.supernodes.width(from)) * (update.last - update.first) * length);
  }
  EXPECT_GE(widest, detail::kBlockedPanelWidth);
  EXPECT_GE(largest_update, detail::kBlockedUpdateWork);
}

TEST(TreeFactorization, WideSupernodesAreBitIdenticalOnAnyNumberOfThreadsAndDefiniteOnlyWhenTheMatrixIs) {
  const auto matrix = matrix_with_a_dense_top();
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 3, 21);
  const Eigen::MatrixXd one = solve_in_arena(matrix, rhs, 1);
  EXPECT_EQ(one, solve_in_arena(matrix, rhs, 2));
  EXPECT_EQ(one, solve_in_arena(matrix, rhs, 3));
  const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> reference(matrix);
  EXPECT_LE(test::relative_difference(one, Eigen::MatrixXd(reference.solve(rhs))), 1e-11);
  // A negative pivot in the clique, eliminated in the wide top supernode.
  SparseCholesky factor;
  EXPECT_THROW(factor.factor(matrix_with_a_dense_top(-100.0), SolverBackend::Tree), SolveError);
}

TEST(TreeFactorization, ReusedAnalysisGivesTheFreshSolution) {
  const auto matrix = split_matrix();
  Eigen::SparseMatrix<double> scaled = 2.5 * matrix;  // same pattern, other values
  for (int k = 0; k < scaled.outerSize(); ++k) scaled.coeffRef(k, k) += 0.01 * (k % 7);
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 3, 13);
  SparseCholesky first, reused, fresh;
  first.factor(matrix, SolverBackend::Tree);
  EXPECT_FALSE(first.reused_analysis());
  reused.factor(scaled, SolverBackend::Tree, {}, first.analysis());
  EXPECT_TRUE(reused.reused_analysis());
  EXPECT_EQ(reused.analysis().get(), first.analysis().get());
  fresh.factor(scaled, SolverBackend::Tree);  // the same AMD order: it depends on the pattern alone
  EXPECT_EQ(reused.solve(rhs), fresh.solve(rhs));
  EXPECT_LE((scaled * reused.solve(rhs) - rhs).norm() / rhs.norm(), 1e-10);

  // Another pattern is analysed afresh.
  Eigen::SparseMatrix<double> other = matrix;
  other.coeffRef(0, matrix.rows() - 1) += 1e-3;
  other.coeffRef(matrix.rows() - 1, 0) += 1e-3;
  other.makeCompressed();
  SparseCholesky not_reused;
  not_reused.factor(other, SolverBackend::Tree, {}, first.analysis());
  EXPECT_FALSE(not_reused.reused_analysis());
  EXPECT_LE((other * not_reused.solve(rhs) - rhs).norm() / rhs.norm(), 1e-10);
}

TEST(TreeFactorization, AGivenOrderIsFollowed) {
  const auto matrix = spd_matrix(make_shape(ShapeKind::Cactus, 12).mesh);
  std::vector<int> reversed(static_cast<std::size_t>(matrix.rows()));
  for (std::size_t i = 0; i < reversed.size(); ++i) reversed[i] = static_cast<int>(reversed.size() - i) * 3;  // any distinct ranks
  SparseCholesky factor;
  factor.factor(matrix, SolverBackend::Tree, reversed);
  for (std::size_t i = 0; i < reversed.size(); ++i) EXPECT_EQ(factor.factor_row()[i], static_cast<int>(reversed.size() - 1 - i));
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 2, 14);
  EXPECT_LE(test::relative_difference(factor.solve(rhs), Eigen::MatrixXd(Eigen::MatrixXd(matrix).ldlt().solve(rhs))), 1e-10);
  EXPECT_THROW(factor.factor(matrix, SolverBackend::Tree, std::span(reversed).first(3)), std::invalid_argument);
}

// Eliminating the free vertices in the order the whole mesh's AMD order induces fills in no more
// than that order fills the whole Laplacian: every fill path among free vertices is one in the
// whole mesh.
TEST(TreeFactorization, TheInducedOrderFillsNoMoreThanTheWholeMesh) {
  const Mesh mesh = make_shape(ShapeKind::Cactus, 32).mesh;
  const auto laplacian = cotangent_laplacian(mesh);
  const auto rank = elimination_ranks(laplacian);
  SparseCholesky whole;
  whole.factor(spd_matrix(mesh), SolverBackend::Tree, rank);
  const auto shape = make_shape(ShapeKind::Cactus, 32);
  const auto partition = partition_vertices(shape.mesh, cotangent_weights(shape.mesh), shape.demo_constraints);
  const DirichletSystem induced(laplacian, partition, SolverBackend::Tree, rank);
  EXPECT_LE(induced.factor().factor_nonzeros(), whole.factor_nonzeros());
  // And it is about as good as an AMD order of L_ff's own.
  const auto& free = partition.free_vertices;
  std::vector<int> free_index(static_cast<std::size_t>(mesh.vertex_count()), -1);
  for (std::size_t k = 0; k < free.size(); ++k) free_index[static_cast<std::size_t>(free[k])] = static_cast<int>(k);
  std::vector<Eigen::Triplet<double>> entries;
  for (int column = 0; column < laplacian.outerSize(); ++column) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(laplacian, column); it; ++it) {
      const int i = free_index[static_cast<std::size_t>(it.row())], j = free_index[static_cast<std::size_t>(column)];
      if (i >= 0 && j >= 0) entries.emplace_back(i, j, it.value());
    }
  }
  Eigen::SparseMatrix<double> free_block(static_cast<Eigen::Index>(free.size()), static_cast<Eigen::Index>(free.size()));
  free_block.setFromTriplets(entries.begin(), entries.end());
  SparseCholesky own;
  own.factor(free_block, SolverBackend::Tree);
  EXPECT_LE(static_cast<double>(induced.factor().factor_nonzeros()), 1.15 * static_cast<double>(own.factor_nonzeros()));
  // Without an order given, a system computes the whole Laplacian's: the same factor.
  const DirichletSystem defaulted(laplacian, partition, SolverBackend::Tree);
  EXPECT_EQ(defaulted.factor().factor_row(), induced.factor().factor_row());
  const DirichletSystem eigen(laplacian, partition, SolverBackend::Eigen);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(mesh.vertex_count(), 1), b = a;
  for (const int v : shape.demo_constraints.handles[0]) a(v, 0) = b(v, 0) = 1.0;
  induced.solve(a);
  eigen.solve(b);
  EXPECT_LE(test::relative_difference(a, b), 1e-12);
  EXPECT_THROW(DirichletSystem(laplacian, partition, SolverBackend::Tree, std::span(rank).first(5)), std::invalid_argument);
}

bool is_permutation(const std::vector<int>& rank) {
  std::vector<bool> seen(rank.size(), false);
  for (const int r : rank) {
    if (r < 0 || static_cast<std::size_t>(r) >= rank.size() || seen[static_cast<std::size_t>(r)]) return false;
    seen[static_cast<std::size_t>(r)] = true;
  }
  return true;
}

// Nested dissection: a permutation, the same one every time, and the induced factorization of a
// selection solves as AMD's does. Two meshes side by side (disconnected) and graphs without edges
// are ordered too.
// A factor larger than the memory left is refused with what it needs and what there is, before
// its values are allocated, rather than left to the system's out-of-memory killer.
TEST(FactorMemory, AFactorLargerThanTheMemoryLeftIsRefusedWithBothFigures) {
  EXPECT_EQ(detail::factor_value_bytes(1000), 16000U);  // rows and columns, in double
  EXPECT_NO_THROW(detail::check_factor_memory(10, 100, std::nullopt));
  EXPECT_NO_THROW(detail::check_factor_memory(10, 100, 100));
  try {
    detail::check_factor_memory(6138826, 9'600'000'000, 8'100'000'000);
    FAIL() << "a factor of 9.6 GB in 8.1 GB was accepted";
  } catch (const SolveError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("6138826-unknown"), std::string::npos) << message;
    EXPECT_NE(message.find("needs 9.6 GB"), std::string::npos) << message;
    EXPECT_NE(message.find("8.1 GB are available"), std::string::npos) << message;
    EXPECT_NE(message.find("multiresolution"), std::string::npos) << message;
  }
#ifdef __linux__
  const auto available = detail::available_memory_bytes();
  ASSERT_TRUE(available.has_value()) << "MemAvailable not read from /proc/meminfo";
  EXPECT_GT(*available, 0U);
  EXPECT_LE(*available, static_cast<std::uint64_t>(sysconf(_SC_PHYS_PAGES)) * static_cast<std::uint64_t>(sysconf(_SC_PAGE_SIZE)));
#endif
}

TEST(EliminationOrder, NestedDissectionGivesAPermutationThatSolvesAlike) {
  const auto shape = make_shape(ShapeKind::Cactus, 32);
  const auto laplacian = cotangent_laplacian(shape.mesh);
  const auto nested = elimination_ranks(laplacian, EliminationOrder::NestedDissection);
  EXPECT_TRUE(is_permutation(nested));
  EXPECT_EQ(elimination_ranks(laplacian, EliminationOrder::NestedDissection), nested);
  const auto minimum_degree = elimination_ranks(laplacian, EliminationOrder::MinimumDegree);
  EXPECT_NE(nested, minimum_degree);
  EXPECT_EQ(elimination_ranks(laplacian), minimum_degree) << "below the threshold, Automatic is AMD";
  const auto partition = partition_vertices(shape.mesh, cotangent_weights(shape.mesh), shape.demo_constraints);
  const DirichletSystem by_nested(laplacian, partition, SolverBackend::Tree, nested);
  const DirichletSystem by_minimum_degree(laplacian, partition, SolverBackend::Tree, minimum_degree);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(shape.mesh.vertex_count(), 1), b = a;
  for (const int v : shape.demo_constraints.handles[0]) a(v, 0) = b(v, 0) = 1.0;
  by_nested.solve(a);
  by_minimum_degree.solve(b);
  EXPECT_LE(test::relative_difference(a, b), 1e-12);
  // About as sparse as AMD's at this size (42,366 against 42,679 nonzeros); METIS's permutation
  // read the wrong way round (its inverse) fills 3.4 times as many.
  EXPECT_LE(static_cast<double>(by_nested.factor().factor_nonzeros()), 1.1 * static_cast<double>(by_minimum_degree.factor().factor_nonzeros()));

  // Two copies of the mesh, unconnected: block diagonal.
  const Eigen::Index n = laplacian.rows();
  std::vector<Eigen::Triplet<double>> entries;
  for (int column = 0; column < laplacian.outerSize(); ++column) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(laplacian, column); it; ++it) {
      entries.emplace_back(static_cast<int>(it.row()), column, it.value());
      entries.emplace_back(static_cast<int>(it.row() + n), static_cast<int>(column + n), it.value());
    }
  }
  Eigen::SparseMatrix<double> pair(2 * n, 2 * n);
  pair.setFromTriplets(entries.begin(), entries.end());
  EXPECT_TRUE(is_permutation(elimination_ranks(pair, EliminationOrder::NestedDissection)));
  for (const Eigen::Index size : {0, 1, 2, 7}) {
    Eigen::SparseMatrix<double> diagonal(size, size);
    diagonal.setIdentity();
    const auto rank = elimination_ranks(diagonal, EliminationOrder::NestedDissection);
    EXPECT_EQ(rank.size(), static_cast<std::size_t>(size));
    EXPECT_TRUE(is_permutation(rank)) << size;
  }
  EXPECT_EQ(elimination_order_for(kNestedDissectionFrom - 1), EliminationOrder::MinimumDegree);
  EXPECT_EQ(elimination_order_for(kNestedDissectionFrom), EliminationOrder::NestedDissection);
}

TEST(ColumnBlocks, EverySchedulePartitionsColumnsAndGivesIdenticalBits) {
  const auto matrix = spd_matrix(make_shape(ShapeKind::Cactus, 16).mesh);
  SparseCholesky factor;
  factor.factor(matrix, SolverBackend::Eigen);
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 5, 9);
  std::vector<Eigen::MatrixXd> results;
  for (const auto schedule : {SolveSchedule::Blocked, SolveSchedule::PerColumn, SolveSchedule::ThreadGroups}) {
    for (const int threads : {1, 2, 3}) {
      ColumnBlocks blocks(matrix.rows(), 5, schedule, threads);
      if (schedule == SolveSchedule::Blocked) {
        EXPECT_EQ(blocks.groups(), 1);
      }
      if (schedule == SolveSchedule::PerColumn) {
        EXPECT_EQ(blocks.groups(), 5);
      }
      if (schedule == SolveSchedule::ThreadGroups) {
        EXPECT_EQ(blocks.groups(), threads);
      }
      for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
        for (int c = 0; c < 5; ++c) blocks.at(factor.factor_row()[static_cast<std::size_t>(i)], c) = rhs(i, c);
      }
      blocks.solve(factor);
      Eigen::MatrixXd solution(matrix.rows(), 5);
      for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
        for (int c = 0; c < 5; ++c) solution(i, c) = blocks.at(factor.factor_row()[static_cast<std::size_t>(i)], c);
      }
      results.push_back(solution);
    }
  }
  EXPECT_LE(test::relative_difference(results[0], factor.solve(rhs)), 0.0);
  for (const auto& result : results) EXPECT_EQ(result, results[0]);
}

TEST(DirichletSystem, SolvesTheConstrainedProblemLikeADenseReference) {
  const Mesh mesh = make_shape(ShapeKind::Cylinder, 16).mesh;
  const auto weights = cotangent_weights(mesh);
  const auto laplacian = cotangent_laplacian(mesh, weights);
  EditConstraints constraints;
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.positions(v, 2) < 0.1) constraints.fixed.push_back(static_cast<int>(v));
    if (mesh.positions(v, 2) > 0.9) {
      if (constraints.handles.empty()) constraints.handles.emplace_back();
      constraints.handles[0].push_back(static_cast<int>(v));
    }
  }
  const auto partition = partition_vertices(mesh, weights, constraints);
  const Eigen::MatrixXd source = test::random_matrix(mesh.vertex_count(), 2, 11);
  Eigen::MatrixXd values = test::random_matrix(mesh.vertex_count(), 2, 12);  // constrained rows: Dirichlet data
  const Eigen::MatrixXd dirichlet = values;

  // Dense reference: eliminate the constrained rows and columns by hand.
  const auto& free = partition.free_vertices;
  const auto& fixed = partition.constrained_vertices;
  const Eigen::MatrixXd full(laplacian);
  Eigen::MatrixXd free_block(free.size(), free.size()), coupling(free.size(), fixed.size());
  for (std::size_t i = 0; i < free.size(); ++i) {
    for (std::size_t j = 0; j < free.size(); ++j) free_block(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = full(free[i], free[j]);
    for (std::size_t j = 0; j < fixed.size(); ++j) coupling(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = full(free[i], fixed[j]);
  }
  Eigen::MatrixXd known(fixed.size(), 2), rhs(free.size(), 2);
  for (std::size_t j = 0; j < fixed.size(); ++j) known.row(static_cast<Eigen::Index>(j)) = dirichlet.row(fixed[j]);
  for (std::size_t i = 0; i < free.size(); ++i) rhs.row(static_cast<Eigen::Index>(i)) = source.row(free[i]);
  const Eigen::MatrixXd expected = free_block.ldlt().solve(rhs - coupling * known);

  for (const auto backend : test::available_backends()) {
    const DirichletSystem system(laplacian, partition, backend);
    Eigen::MatrixXd solved = dirichlet;
    system.solve(solved, &source);
    Eigen::MatrixXd solved_free(free.size(), 2);
    for (std::size_t i = 0; i < free.size(); ++i) solved_free.row(static_cast<Eigen::Index>(i)) = solved.row(free[i]);
    EXPECT_LE(test::relative_difference(solved_free, expected), 1e-10) << to_string(backend);
    for (const int v : fixed) EXPECT_EQ(solved.row(v), dirichlet.row(v));
  }
}

}  // namespace
}  // namespace hdeform

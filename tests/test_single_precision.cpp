// Single-precision factors: L rounded to float, every solve refined against A in double.
#include <Eigen/Dense>
#include <tbb/task_arena.h>

#include <limits>

#include "hdeform/deformer.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/laplacian.h"
#include "hdeform/shapes.h"
#include "hdeform/sparse_cholesky.h"
#include "test_support.h"

namespace hdeform {
namespace {

// A Laplacian made definite by a small shift: well conditioned enough for single precision.
Eigen::SparseMatrix<double> shifted_laplacian(const Mesh& mesh) {
  const auto n = mesh.vertex_count();
  Eigen::SparseMatrix<double> identity(n, n);
  identity.setIdentity();
  return cotangent_laplacian(mesh) + 1e-3 * identity;
}

// The path graph's Laplacian held at one end: condition number about 1.6·n², so single
// precision (2⁻²⁴ ≈ 6e-8) stops paying somewhere past n ≈ 300.
Eigen::SparseMatrix<double> chain(int n) {
  std::vector<Eigen::Triplet<double>> entries;
  for (int i = 0; i < n; ++i) {
    entries.emplace_back(i, i, i + 1 < n ? 2.0 : 1.0);
    if (i + 1 < n) {
      entries.emplace_back(i, i + 1, -1.0);
      entries.emplace_back(i + 1, i, -1.0);
    }
  }
  Eigen::SparseMatrix<double> matrix(n, n);
  matrix.setFromTriplets(entries.begin(), entries.end());
  return matrix;
}

TEST(SinglePrecision, MatchesTheDoubleSolveAndADenseOne) {
  const auto matrix = shifted_laplacian(make_shape(ShapeKind::Cactus, 12).mesh);
  const Eigen::MatrixXd dense(matrix);
  for (const auto backend : test::available_backends()) {
    SCOPED_TRACE(std::string(to_string(backend)));
    SparseCholesky in_double, in_single;
    in_double.factor(matrix, backend);
    in_single.factor(matrix, backend, {}, nullptr, FactorPrecision::Single);
    EXPECT_EQ(in_double.precision(), FactorPrecision::Double);
    ASSERT_EQ(in_single.precision(), FactorPrecision::Single) << in_single.precision_note();
    EXPECT_TRUE(in_single.precision_note().empty());
    // One kernel pass (5 columns) and several (19: more than the 8 one pass takes).
    for (const int columns : {5, 19}) {
      const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), columns, static_cast<unsigned>(columns));
      const Eigen::MatrixXd expected = dense.ldlt().solve(rhs);
      const Eigen::MatrixXd solved = in_single.solve(rhs);
      // The float factor alone is about 1e-7 off.
      EXPECT_LE(test::relative_difference(solved, expected), 1e-10) << columns;
      EXPECT_LE(test::relative_difference(solved, in_double.solve(rhs)), 1e-10) << columns;
    }
    // Every solve needed at least one correction, and the residual test stopped each without
    // stalling.
    const auto refinement = in_single.refinement();
    EXPECT_EQ(refinement.solves, 2);
    EXPECT_GE(refinement.corrections, 2);
    EXPECT_GE(refinement.most_corrections, 1);
    EXPECT_LE(refinement.most_corrections, 3);
    EXPECT_EQ(refinement.stalled, 0);
    EXPECT_GT(refinement.contraction, 0.0);
    EXPECT_LT(refinement.contraction, 1e-3);
    EXPECT_EQ(in_double.refinement().solves, 0);
  }
}

TEST(SinglePrecision, GivesTheSameBitsOnAnyNumberOfThreadsAndConcurrently) {
  const auto matrix = shifted_laplacian(make_shape(ShapeKind::Cactus, 48).mesh);
  SparseCholesky factor;
  factor.factor(matrix, SolverBackend::Tree, {}, nullptr, FactorPrecision::Single);
  ASSERT_EQ(factor.precision(), FactorPrecision::Single);
  const Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 3, 7);
  Eigen::MatrixXd on_one, on_two;
  tbb::task_arena(1).execute([&] { on_one = factor.solve(rhs); });
  tbb::task_arena(2).execute([&] { on_two = factor.solve(rhs); });
  EXPECT_EQ(on_one, on_two);
  // Columns solved concurrently (one solve_block call per group, each with its own workspace)
  // give each column's bits as a solve of it alone.
  ColumnBlocks blocks(matrix.rows(), 3, SolveSchedule::PerColumn);
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
    for (int c = 0; c < 3; ++c) blocks.at(factor.factor_row()[static_cast<std::size_t>(i)], c) = rhs(i, c);
  }
  blocks.solve(factor);
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd alone = factor.solve(rhs.col(c));
    for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
      ASSERT_EQ(blocks.at(factor.factor_row()[static_cast<std::size_t>(i)], c), alone(i)) << "column " << c << ", row " << i;
    }
  }
}

// A right-hand side with a NaN cannot pass the residual test: the solve stops as stalled and the
// NaN reaches the result instead of a converged-looking answer.
TEST(SinglePrecision, ANotANumberNeverPassesTheResidualTest) {
  const auto matrix = shifted_laplacian(make_shape(ShapeKind::Cactus, 12).mesh);
  SparseCholesky factor;
  factor.factor(matrix, SolverBackend::Tree, {}, nullptr, FactorPrecision::Single);
  ASSERT_EQ(factor.precision(), FactorPrecision::Single);
  Eigen::MatrixXd rhs = test::random_matrix(matrix.rows(), 3, 23);
  rhs(matrix.rows() / 2, 1) = std::numeric_limits<double>::quiet_NaN();
  const Eigen::MatrixXd solved = factor.solve(rhs);
  EXPECT_TRUE(solved.col(1).array().isNaN().any());
  EXPECT_EQ(factor.refinement().stalled, 1);
}

TEST(SinglePrecision, RefusesAMatrixTooIllConditionedAndSaysSo) {
  // A short chain is fine in single precision; a long one is not, and keeps its double factor.
  SparseCholesky short_chain;
  short_chain.factor(chain(50), SolverBackend::Tree, {}, nullptr, FactorPrecision::Single);
  EXPECT_EQ(short_chain.precision(), FactorPrecision::Single) << short_chain.precision_note();

  // Every backend: ours computes the double factor again, the others keep theirs until the probe.
  const auto matrix = chain(20'000);
  Eigen::VectorXd known(matrix.rows());
  for (Eigen::Index i = 0; i < known.size(); ++i) known(i) = std::sin(0.001 * static_cast<double>(i));
  const Eigen::VectorXd rhs = matrix * known;
  for (const auto backend : test::available_backends()) {
    SCOPED_TRACE(std::string(to_string(backend)));
    SparseCholesky long_chain;
    long_chain.factor(matrix, backend, {}, nullptr, FactorPrecision::Single);
    EXPECT_EQ(long_chain.precision(), FactorPrecision::Double);
    EXPECT_NE(long_chain.precision_note().find("too ill-conditioned for a single-precision factor"), std::string::npos)
        << long_chain.precision_note();
    // Still a correct solve, in double (the chain's condition number, 6e8, allows about 1e-7).
    EXPECT_LE(test::relative_difference(long_chain.solve(rhs), known), 1e-6);
    EXPECT_EQ(long_chain.refinement().solves, 0);
  }
}

TEST(SinglePrecision, ADeformersUpdateAndRefinementMatchDoubleOnBothResolutions) {
  const auto shape = make_shape(ShapeKind::Cactus, 48);
  const HandleTransform transform = shape.demo_transform;
  for (const auto resolution : {Resolution::Exact, Resolution::Multiresolution}) {
    SCOPED_TRACE(std::string(to_string(resolution)));
    DeformerOptions options;
    options.resolution = resolution;
    options.base_vertices = shape.mesh.vertex_count() / 4;
    Deformer in_double(shape.mesh, shape.demo_constraints, options);
    options.precision = FactorPrecision::Single;
    Deformer in_single(shape.mesh, shape.demo_constraints, options);
    ASSERT_EQ(in_single.system().factor().precision(), FactorPrecision::Single);
    Eigen::MatrixXd expected, positions;
    in_double.deform(std::span(&transform, 1), expected);
    in_single.deform(std::span(&transform, 1), positions);
    const double diagonal = bounding_box_diagonal(shape.mesh.positions);
    EXPECT_LE((positions - expected).cwiseAbs().maxCoeff(), 1e-10 * diagonal);
    in_double.refine(expected, 8);
    in_single.refine(positions, 8);
    EXPECT_LE((positions - expected).cwiseAbs().maxCoeff(), 1e-10 * diagonal);
    // Constraints stay exact: they are placed, not solved.
    for (const int v : shape.demo_constraints.fixed) EXPECT_EQ(positions.row(v), shape.mesh.positions.row(v));
    const auto refinement = in_single.system().factor().refinement();
    EXPECT_GE(refinement.solves, 9);  // the field's, the update's, the refinement's
    EXPECT_GE(refinement.corrections, refinement.solves);
  }
}

}  // namespace
}  // namespace hdeform

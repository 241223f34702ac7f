#include <Eigen/Dense>

#include "hdeform/constraints.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/harmonic_field.h"
#include "hdeform/laplacian.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

struct FieldCase {
  Mesh mesh;
  CotangentWeights weights;
  VertexPartition partition;
  Eigen::SparseMatrix<double> laplacian;
};

FieldCase demo_case(ShapeKind kind, int resolution) {
  auto shape = make_shape(kind, resolution);
  FieldCase c;
  c.mesh = std::move(shape.mesh);
  c.weights = cotangent_weights(c.mesh);
  c.partition = partition_vertices(c.mesh, c.weights, shape.demo_constraints);
  c.laplacian = cotangent_laplacian(c.mesh, c.weights);
  return c;
}

std::vector<std::vector<int>> neighbours(const Mesh& mesh) {
  std::vector<std::vector<int>> around(static_cast<std::size_t>(mesh.vertex_count()));
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.triangles(t, k), b = mesh.triangles(t, (k + 1) % 3);
      around[static_cast<std::size_t>(a)].push_back(b);
      around[static_cast<std::size_t>(b)].push_back(a);
    }
  }
  return around;
}

TEST(HarmonicField, IsOneAtSourcesZeroAtSinksAndWithinTheUnitInterval) {
  const auto c = demo_case(ShapeKind::Cactus, 32);
  const DirichletSystem system(c.laplacian, c.partition, SolverBackend::Eigen);
  const Eigen::VectorXd h = harmonic_field(system, c.partition);
  for (std::size_t v = 0; v < c.partition.role.size(); ++v) {
    const auto row = static_cast<Eigen::Index>(v);
    if (c.partition.role[v] == VertexRole::Handle) {
      EXPECT_EQ(h(row), 1.0);
    }
    if (c.partition.role[v] == VertexRole::Fixed) {
      EXPECT_EQ(h(row), 0.0);
    }
  }
  EXPECT_GE(h.minCoeff(), 0.0);
  EXPECT_LE(h.maxCoeff(), 1.0);
  // Not trivially constant: it spans the interval.
  EXPECT_GT((h.array() > 0.1 && h.array() < 0.9).count(), h.size() / 4);
}

TEST(HarmonicField, HasNoInteriorExtremum) {
  // On a mesh whose cotangent weights are all non-negative the discrete maximum principle holds
  // strictly: every free value lies within the range of its neighbours.
  const int cells = 16;
  const Mesh grid = test::planar_grid(cells);
  const auto weights = cotangent_weights(grid);
  ASSERT_GE(weights.half_cotangent.minCoeff(), -1e-15);
  EditConstraints constraints;
  constraints.handles = {{0, 1, cells + 1}};                        // a corner
  constraints.fixed = {(cells + 1) * (cells + 1) - 1, (cells + 1) * (cells + 1) - 2};  // the far corner
  const auto partition = partition_vertices(grid, weights, constraints);
  const DirichletSystem system(cotangent_laplacian(grid, weights), partition, SolverBackend::Eigen);
  const Eigen::VectorXd h = harmonic_field(system, partition);
  const auto around = neighbours(grid);
  for (const int v : partition.free_vertices) {
    double low = 2.0, high = -1.0;
    for (const int u : around[static_cast<std::size_t>(v)]) {
      low = std::min(low, h(u));
      high = std::max(high, h(u));
    }
    EXPECT_GE(h(v), low - 1e-14) << v;
    EXPECT_LE(h(v), high + 1e-14) << v;
  }
  // On the cactus (some obtuse triangles) no free vertex is a strict local extremum.
  const auto c = demo_case(ShapeKind::Cactus, 24);
  const DirichletSystem cactus_system(c.laplacian, c.partition, SolverBackend::Eigen);
  const Eigen::VectorXd cactus_h = harmonic_field(cactus_system, c.partition);
  const auto cactus_around = neighbours(c.mesh);
  for (const int v : c.partition.free_vertices) {
    bool above_all = true, below_all = true;
    for (const int u : cactus_around[static_cast<std::size_t>(v)]) {
      above_all = above_all && cactus_h(v) > cactus_h(u);
      below_all = below_all && cactus_h(v) < cactus_h(u);
    }
    EXPECT_FALSE(above_all || below_all) << "vertex " << v << " is a local extremum";
  }
}

TEST(HarmonicField, EqualsADenseSolve) {
  const auto c = demo_case(ShapeKind::Cactus, 12);
  // Reference built from the brute-force gradient form of the Laplacian and a dense solve.
  const Eigen::MatrixXd full(c.laplacian);
  const auto& free = c.partition.free_vertices;
  Eigen::MatrixXd block(free.size(), free.size());
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(free.size()));
  for (std::size_t i = 0; i < free.size(); ++i) {
    for (std::size_t j = 0; j < free.size(); ++j) block(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = full(free[i], free[j]);
    for (Eigen::Index v = 0; v < c.mesh.vertex_count(); ++v) {
      if (c.partition.role[static_cast<std::size_t>(v)] == VertexRole::Handle) rhs(static_cast<Eigen::Index>(i)) -= full(free[i], v);
    }
  }
  const Eigen::VectorXd expected = block.ldlt().solve(rhs);
  for (const auto backend : kSolverBackends) {
    if (!backend_available(backend)) continue;
    const DirichletSystem system(c.laplacian, c.partition, backend);
    const Eigen::VectorXd h = harmonic_field(system, c.partition);
    Eigen::VectorXd h_free(static_cast<Eigen::Index>(free.size()));
    for (std::size_t i = 0; i < free.size(); ++i) h_free(static_cast<Eigen::Index>(i)) = h(free[i]);
    EXPECT_LE(test::relative_difference(h_free, expected), 1e-10) << to_string(backend);
  }
}

TEST(HarmonicField, BackendsAgree) {
  if (!backend_available(SolverBackend::Cholmod)) GTEST_SKIP() << "this build has no CHOLMOD backend";
  const auto c = demo_case(ShapeKind::Cactus, 48);
  const DirichletSystem eigen(c.laplacian, c.partition, SolverBackend::Eigen);
  const DirichletSystem cholmod(c.laplacian, c.partition, SolverBackend::Cholmod);
  const Eigen::VectorXd a = harmonic_field(eigen, c.partition), b = harmonic_field(cholmod, c.partition);
  EXPECT_LE((a - b).norm() / a.norm(), 1e-10);
}

TEST(HarmonicField, AnUnconstrainedComponentStaysAtZeroAndTheSolveStaysDefinite) {
  // Two disjoint cactuses; only the first has constraints.
  auto shape = make_shape(ShapeKind::Cactus, 12);
  Mesh two;
  const auto n = shape.mesh.vertex_count();
  two.positions.resize(2 * n, 3);
  two.positions << shape.mesh.positions, shape.mesh.positions.rowwise() + Eigen::RowVector3d(1.0, 0.0, 0.0);
  two.triangles.resize(2 * shape.mesh.triangle_count(), 3);
  two.triangles << shape.mesh.triangles, shape.mesh.triangles.array() + static_cast<int>(n);
  const auto weights = cotangent_weights(two);
  const auto partition = partition_vertices(two, weights, shape.demo_constraints);
  EXPECT_EQ(partition.stray_components, 1u);
  EXPECT_EQ(partition.stray_vertices, static_cast<std::size_t>(n));
  ASSERT_FALSE(partition.warnings.empty());
  const DirichletSystem system(cotangent_laplacian(two, weights), partition, SolverBackend::Eigen);
  const Eigen::VectorXd h = harmonic_field(system, partition);
  EXPECT_TRUE(h.allFinite());
  EXPECT_EQ(h.tail(n).cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace hdeform

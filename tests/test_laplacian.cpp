#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "hdeform/laplacian.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

Eigen::MatrixXd dense(const Eigen::SparseMatrix<double>& matrix) { return Eigen::MatrixXd(matrix); }

// Independent reference: L_ij = Σ_t A_t ∇φ_i·∇φ_j with ∇φ_i = n × e_i / (2A), e_i the edge
// opposite vertex i, counter-clockwise (design.md).
Eigen::MatrixXd brute_force_laplacian(const Mesh& mesh) {
  const auto n = mesh.vertex_count();
  Eigen::MatrixXd laplacian = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    Eigen::Vector3d p[3];
    for (int k = 0; k < 3; ++k) p[k] = mesh.positions.row(mesh.triangles(t, k));
    const Eigen::Vector3d normal_times_2a = (p[1] - p[0]).cross(p[2] - p[0]);
    const double area = 0.5 * normal_times_2a.norm();
    const Eigen::Vector3d normal = normal_times_2a.normalized();
    Eigen::Vector3d gradient[3];
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d opposite_edge = p[(k + 2) % 3] - p[(k + 1) % 3];
      gradient[k] = normal.cross(opposite_edge) / (2.0 * area);
    }
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) laplacian(mesh.triangles(t, a), mesh.triangles(t, b)) += area * gradient[a].dot(gradient[b]);
    }
  }
  return laplacian;
}

TEST(Laplacian, IsSymmetricWithZeroRowSums) {
  for (const auto& mesh : {test::planar_grid(12, 1.0, 0.3), make_shape(ShapeKind::Cactus, 16).mesh}) {
    const auto laplacian = cotangent_laplacian(mesh);
    const Eigen::SparseMatrix<double> transpose = laplacian.transpose();
    EXPECT_EQ((laplacian - transpose).norm(), 0.0);
    const Eigen::VectorXd row_sums = laplacian * Eigen::VectorXd::Ones(mesh.vertex_count());
    const double scale = laplacian.diagonal().cwiseAbs().maxCoeff();
    EXPECT_LE(row_sums.cwiseAbs().maxCoeff(), 1e-13 * scale);
  }
}

TEST(Laplacian, VanishesOnLinearFunctionsAtInteriorVerticesOfAPlanarMesh) {
  const int cells = 10;
  const Mesh mesh = test::planar_grid(cells, 2.0, 0.35);  // irregular, with obtuse triangles
  const auto laplacian = cotangent_laplacian(mesh);
  const Eigen::VectorXd linear = 0.7 * mesh.positions.col(0) - 1.3 * mesh.positions.col(1) + Eigen::VectorXd::Constant(mesh.vertex_count(), 2.5);
  const Eigen::VectorXd result = laplacian * linear;
  std::vector<bool> on_boundary(static_cast<std::size_t>(mesh.vertex_count()), false);
  for (const int v : test::grid_boundary(cells)) on_boundary[static_cast<std::size_t>(v)] = true;
  int interior = 0;
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    if (on_boundary[static_cast<std::size_t>(v)]) continue;
    ++interior;
    EXPECT_NEAR(result(v), 0.0, 1e-12) << "vertex " << v;
  }
  EXPECT_GT(interior, 50);
  // The boundary rows do not vanish: the test can tell.
  EXPECT_GT(result.cwiseAbs().maxCoeff(), 1e-3);
}

TEST(Laplacian, EqualsBruteForceGradientAssembly) {
  for (const auto& mesh : {test::planar_grid(6, 1.0, 0.3), make_shape(ShapeKind::Cactus, 12).mesh, make_shape(ShapeKind::Sphere, 12).mesh}) {
    const auto weights = cotangent_weights(mesh);
    ASSERT_EQ(weights.count(ElementKind::Regular), static_cast<std::size_t>(mesh.triangle_count()));
    const Eigen::MatrixXd expected = brute_force_laplacian(mesh);
    EXPECT_LE(test::relative_difference(dense(cotangent_laplacian(mesh)), expected), 1e-12);
  }
}

TEST(Laplacian, ObtuseTrianglesGiveNegativeButFiniteWeights) {
  Mesh mesh;
  mesh.positions.resize(4, 3);
  mesh.positions << 0, 0, 0, 1, 0, 0, 0.5, 0.05, 0, 0.5, -1, 0;  // vertex 2 has an angle near 180°
  mesh.triangles.resize(2, 3);
  mesh.triangles << 0, 1, 2, 1, 0, 3;
  const auto weights = cotangent_weights(mesh);
  EXPECT_EQ(weights.kind[0], ElementKind::Regular);
  EXPECT_LT(weights.half_cotangent(0, 2), 0.0);
  EXPECT_TRUE(weights.half_cotangent.allFinite());
}

TEST(Laplacian, DegenerateTrianglesStayFiniteAndPositiveSemidefinite) {
  Mesh mesh;
  mesh.positions.resize(7, 3);
  mesh.positions << 0, 0, 0,   // 0
      1, 0, 0,                 // 1
      0, 1, 0,                 // 2
      2, 0, 0,                 // 3: collinear with 0, 1
      1, 1e-14, 0,             // 4: a needle over edge 1-3
      1, 0, 0,                 // 5: coincides with vertex 1
      0.5, 0.5, 1;             // 6
  mesh.triangles.resize(8, 3);
  mesh.triangles << 0, 1, 2,  // regular
      0, 3, 1,                // zero area (collinear)
      1, 3, 4,                // needle
      1, 5, 2,                // two corners at one point
      0, 0, 2,                // repeated index
      2, 1, 0,                // duplicate of the first (reversed)
      0, 1, 6,                // regular
      2, 6, 1;                // regular
  const auto weights = cotangent_weights(mesh);
  EXPECT_EQ(weights.kind[0], ElementKind::Regular);
  EXPECT_EQ(weights.kind[1], ElementKind::Degenerate);
  EXPECT_EQ(weights.kind[2], ElementKind::Degenerate);
  EXPECT_EQ(weights.kind[3], ElementKind::Degenerate);
  EXPECT_EQ(weights.kind[4], ElementKind::Ignored);
  EXPECT_EQ(weights.kind[5], ElementKind::Ignored);
  EXPECT_TRUE(weights.half_cotangent.allFinite());
  EXPECT_LE(weights.half_cotangent.cwiseAbs().maxCoeff(), 0.5 * kMaxCotangent);

  const Eigen::MatrixXd laplacian = dense(cotangent_laplacian(mesh, weights));
  ASSERT_TRUE(laplacian.allFinite());
  EXPECT_EQ((laplacian - laplacian.transpose()).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(laplacian);
  EXPECT_GE(eigen.eigenvalues().minCoeff(), -1e-9 * eigen.eigenvalues().maxCoeff());
}

TEST(Laplacian, ScaledDegenerateElementIsPositiveSemidefiniteWhereClampingIsNot) {
  // A needle with angles (ε, ε, π − 2ε): clamping each cotangent separately to ±B would give
  // (B, B, −B) and an indefinite element; one common scale keeps c1c2 + c2c3 + c3c1 ≥ 0.
  Mesh mesh;
  mesh.positions.resize(3, 3);
  mesh.positions << 0, 0, 0, 1, 0, 0, 0.5, 1e-9, 0;
  mesh.triangles.resize(1, 3);
  mesh.triangles << 0, 1, 2;
  const auto weights = cotangent_weights(mesh);
  ASSERT_EQ(weights.kind[0], ElementKind::Degenerate);
  const Eigen::Vector3d c = 2.0 * weights.half_cotangent.row(0).transpose();
  EXPECT_GE(c(0) * c(1) + c(1) * c(2) + c(2) * c(0), -1e-9 * c.squaredNorm());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(dense(cotangent_laplacian(mesh, weights)));
  EXPECT_GE(eigen.eigenvalues().minCoeff(), -1e-9 * eigen.eigenvalues().maxCoeff());
}

}  // namespace
}  // namespace hdeform

#include <tbb/task_arena.h>

#include <memory>
#include <random>

#include "hdeform/deformation_field.h"
#include "hdeform/deformer.h"
#include "hdeform/laplacian.h"
#include "hdeform/poisson.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

TEST(BlendMaps, TableTrigonometryMatchesTheDirectRotation) {
  std::mt19937 random(3);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::VectorXd h(2000);
  for (Eigen::Index t = 0; t < h.size(); ++t) h(t) = uniform(random);
  h(0) = 0.0;
  h(1) = 1.0;
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  for (const double angle : {0.0, 1e-7, 0.3, 3.14159, -2.5, 4.0 * 3.141592653589793, 61.0}) {
    const auto handle = HandleTransform::about_pivot(axis, Eigen::Vector3d(0.1, 0.2, 0.3), angle, 1.3);
    AxialMaps maps;
    sample_blend_maps(h, handle, maps);
    double worst = 0.0;
    for (Eigen::Index t = 0; t < h.size(); ++t) {
      const Eigen::Matrix3d direct = blend_scale(handle, h(t)) * blend_rotation(handle, h(t)).toRotationMatrix();
      worst = std::max(worst, (maps.matrix(static_cast<std::size_t>(t)) - direct).cwiseAbs().maxCoeff());
    }
    // h·θ itself carries a rounding error proportional to |θ|.
    EXPECT_LE(worst, 1e-14 * std::max(1.0, std::abs(angle) / 12.0)) << "angle " << angle;
  }
}

// The maps are computed four triangles at a time, a short last group padded: each triangle must
// get the bits it gets alone (a group of one), wherever it falls in a group.
TEST(BlendMaps, FourAtATimeGiveTheBitsOfOneAtATime) {
  std::mt19937 random(4);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::VectorXd h(2003);  // 500 groups of four and a group of three
  for (Eigen::Index t = 0; t < h.size(); ++t) h(t) = uniform(random);
  // The ends of the range, and values a rounding beyond them (barycentric means of 0 and 1).
  h(0) = 0.0;
  h(5) = 1.0;
  h(10) = 1.0 + 2e-16;
  h(15) = -1e-17;
  h(2002) = 1.0;
  const auto handle = HandleTransform::about_pivot(Eigen::Vector3d(0.3, 0.4, -0.5).normalized(), Eigen::Vector3d::Zero(), 2.2, 0.8);
  AxialMaps together, alone;
  sample_blend_maps(h, handle, together);
  ASSERT_EQ(together.coefficients.size(), static_cast<std::size_t>(h.size()));
  Eigen::VectorXd one(1);
  for (Eigen::Index t = 0; t < h.size(); ++t) {
    one(0) = h(t);
    sample_blend_maps(one, handle, alone);
    ASSERT_EQ(together.coefficients[static_cast<std::size_t>(t)], alone.coefficients[0]) << "triangle " << t << ", h = " << h(t);
  }
}

// Several handles' maps, four triangles at a time: each must be, to the bit, what Eigen makes of
// the triangle alone (the mean of its corners' components, the unit quaternion or the identity
// for a near-zero one, its rotation matrix, the scale), including a short last group.
TEST(InterpolatedMaps, FourAtATimeGiveEigensBitsForEachTriangle) {
  std::mt19937 random(6);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const Eigen::Index vertices = 300, triangle_count = 1003;
  Eigen::Matrix<double, Eigen::Dynamic, kInterpolatedComponents, Eigen::RowMajor> components(vertices, kInterpolatedComponents);
  for (Eigen::Index v = 0; v < vertices; ++v) {
    for (int c = 0; c < kInterpolatedComponents; ++c) components(v, c) = uniform(random);
  }
  components.row(7).setZero();  // a quaternion that vanishes: the identity, scaled by zero
  components.row(8) << 1e-14, -1e-14, 0.0, 0.0, 2.0;  // below the norm's threshold
  Eigen::MatrixXi triangles(triangle_count, 3);
  for (Eigen::Index t = 0; t < triangle_count; ++t) {
    for (int k = 0; k < 3; ++k) triangles(t, k) = static_cast<int>(std::uniform_int_distribution<Eigen::Index>(0, vertices - 1)(random));
  }
  triangles.row(0) << 7, 7, 7;
  triangles.row(1) << 8, 8, 8;
  triangles.row(1002) << 7, 8, 7;
  std::vector<Eigen::Matrix3d> maps;
  sample_interpolated_maps(components, triangles, maps);
  ASSERT_EQ(maps.size(), static_cast<std::size_t>(triangle_count));
  for (Eigen::Index t = 0; t < triangle_count; ++t) {
    const InterpolatedValue mean = (components.row(triangles(t, 0)) + components.row(triangles(t, 1)) + components.row(triangles(t, 2))) / 3.0;
    const Eigen::Vector4d wxyz = mean.head<4>().transpose();
    const double norm = wxyz.norm();
    const Eigen::Quaterniond unit = norm > 1e-12 ? Eigen::Quaterniond(wxyz(0) / norm, wxyz(1) / norm, wxyz(2) / norm, wxyz(3) / norm)
                                                 : Eigen::Quaterniond::Identity();
    const Eigen::Matrix3d expected = mean(4) * unit.toRotationMatrix();
    ASSERT_EQ(maps[static_cast<std::size_t>(t)], expected) << "triangle " << t;
  }
  EXPECT_EQ(maps[1], 2.0 * Eigen::Matrix3d::Identity());
}

TEST(PoissonAssembler, AxialAndMatrixMapsGiveTheSameRightHandSide) {
  auto shape = make_shape(ShapeKind::Cactus, 32);
  const auto weights = cotangent_weights(shape.mesh);
  const auto partition = partition_vertices(shape.mesh, weights, shape.demo_constraints);
  const DirichletSystem system(cotangent_laplacian(shape.mesh, weights), partition, SolverBackend::Eigen);
  const PoissonAssembler assembler(shape.mesh, weights, system);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::VectorXd h(shape.mesh.triangle_count());
  for (Eigen::Index t = 0; t < h.size(); ++t) h(t) = uniform(random);
  AxialMaps axial;
  sample_blend_maps(h, shape.demo_transform, axial);
  std::vector<Eigen::Matrix3d> matrices(axial.coefficients.size());
  for (std::size_t t = 0; t < matrices.size(); ++t) matrices[t] = axial.matrix(t);

  ColumnBlocks from_axial(system.free_count(), 3, SolveSchedule::Blocked), from_matrices(system.free_count(), 3, SolveSchedule::Blocked);
  assembler.assemble(axial, shape.mesh.positions, from_axial);
  assembler.assemble(matrices, shape.mesh.positions, from_matrices);
  double scale = 0.0, worst = 0.0;
  for (Eigen::Index row = 0; row < system.free_count(); ++row) {
    for (int c = 0; c < 3; ++c) {
      scale = std::max(scale, std::abs(from_matrices.at(row, c)));
      worst = std::max(worst, std::abs(from_axial.at(row, c) - from_matrices.at(row, c)));
    }
  }
  EXPECT_GT(scale, 0.0);
  EXPECT_LE(worst, 1e-12 * scale);
}

// The assembler gathers each row's corners with one chunk of triangles per thread; the corners
// must come out in triangle order whatever the chunks, so a right-hand side's bits do not depend
// on the thread count of the arena the assembler was made in.
TEST(PoissonAssembler, TheSameBitsWhateverTheThreadsThatGatheredTheCorners) {
  auto shape = make_shape(ShapeKind::Cactus, 32);
  const auto weights = cotangent_weights(shape.mesh);
  const auto partition = partition_vertices(shape.mesh, weights, shape.demo_constraints);
  const DirichletSystem system(cotangent_laplacian(shape.mesh, weights), partition, SolverBackend::Eigen);
  std::mt19937 random(8);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Eigen::Matrix3d> maps(static_cast<std::size_t>(shape.mesh.triangle_count()));
  for (auto& map : maps) map = Eigen::Matrix3d::NullaryExpr([&] { return uniform(random); });
  std::vector<std::vector<double>> results;
  for (const int threads : {1, 3, 5}) {
    tbb::task_arena arena(threads);
    const auto assembler = arena.execute([&] { return std::make_unique<PoissonAssembler>(shape.mesh, weights, system); });
    ColumnBlocks rhs(system.free_count(), 3, SolveSchedule::Blocked);
    assembler->assemble(maps, shape.mesh.positions, rhs);
    std::vector<double>& values = results.emplace_back();
    for (Eigen::Index row = 0; row < system.free_count(); ++row) {
      for (int c = 0; c < 3; ++c) values.push_back(rhs.at(row, c));
    }
  }
  EXPECT_EQ(results[1], results[0]);
  EXPECT_EQ(results[2], results[0]);
}

TEST(PoissonAssembler, IdentityMapsGiveTheLaplacianOfThePositions) {
  // b = L p when every T_t = I: with the constrained part moved to the right-hand side,
  // b_f − L_fc p_c = L_ff p_f.
  auto shape = make_shape(ShapeKind::Sphere, 24);
  const auto weights = cotangent_weights(shape.mesh);
  const auto partition = partition_vertices(shape.mesh, weights, shape.demo_constraints);
  const auto laplacian = cotangent_laplacian(shape.mesh, weights);
  const DirichletSystem system(laplacian, partition, SolverBackend::Eigen);
  const PoissonAssembler assembler(shape.mesh, weights, system);
  const std::vector<Eigen::Matrix3d> identity(static_cast<std::size_t>(shape.mesh.triangle_count()), Eigen::Matrix3d::Identity());
  ColumnBlocks rhs(system.free_count(), 3, SolveSchedule::Blocked);
  assembler.assemble(identity, shape.mesh.positions, rhs);
  Eigen::MatrixXd free_positions = shape.mesh.positions;
  for (const int v : partition.constrained_vertices) free_positions.row(v).setZero();
  const Eigen::MatrixXd expected = laplacian * free_positions;
  double worst = 0.0;
  for (Eigen::Index row = 0; row < system.free_count(); ++row) {
    const int v = system.vertex_of_row()[static_cast<std::size_t>(row)];
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(rhs.at(row, c) - expected(v, c)));
  }
  EXPECT_LE(worst, 1e-13 * expected.cwiseAbs().maxCoeff());
}

}  // namespace
}  // namespace hdeform

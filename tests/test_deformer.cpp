#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <numbers>

#include "hdeform/deformation_field.h"
#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/laplacian.h"
#include "hdeform/poisson.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

constexpr double kPi = std::numbers::pi;

HandleTransform rigid(const Eigen::Vector3d& axis, double degrees, const Eigen::Vector3d& translation) {
  Eigen::Matrix<double, 3, 4> affine;
  affine << Eigen::AngleAxisd(degrees * kPi / 180.0, axis.normalized()).toRotationMatrix(), translation;
  return HandleTransform::from_affine(affine);
}

TEST(Reconstruction, NothingMovedReproducesTheInput) {
  for (const auto kind : {ShapeKind::Cactus, ShapeKind::Bar, ShapeKind::Sphere}) {
    auto shape = make_shape(kind, 32);
    Deformer deformer(shape.mesh, shape.demo_constraints);
    Eigen::MatrixXd positions;
    const HandleTransform identity = HandleTransform::identity();
    deformer.deform(std::span(&identity, 1), positions);
    EXPECT_LE(test::relative_difference(positions, shape.mesh.positions), 1e-9) << to_string(kind);
  }
}

TEST(Reconstruction, OneRotationEverywhereRebuildsARigidMotionExactly) {
  // Every triangle turned by the same R, one vertex pinned where the motion takes it: the Poisson
  // solve returns the whole mesh moved rigidly.
  const auto shape = make_shape(ShapeKind::Cactus, 32);
  const auto transform = rigid(Eigen::Vector3d(1, 2, 3), 80.0, Eigen::Vector3d(0.3, -0.2, 0.5));
  const auto weights = cotangent_weights(shape.mesh);
  EditConstraints pin;
  pin.fixed = {0};
  const auto partition = partition_vertices(shape.mesh, weights, pin);
  const DirichletSystem system(cotangent_laplacian(shape.mesh, weights), partition, default_backend());
  const PoissonAssembler assembler(shape.mesh, weights, system);
  const std::vector<Eigen::Matrix3d> maps(static_cast<std::size_t>(shape.mesh.triangle_count()), transform.linear);
  Eigen::MatrixXd positions = shape.mesh.positions;
  positions.row(0) = transform.apply(shape.mesh.positions.row(0).transpose()).transpose();
  poisson_reconstruct(assembler, system, maps, positions);
  const Eigen::MatrixXd expected = (shape.mesh.positions * transform.linear.transpose()).rowwise() + transform.translation.transpose();
  EXPECT_LE((positions - expected).cwiseAbs().maxCoeff(), 1e-9 * bounding_box_diagonal(shape.mesh.positions));
}

TEST(Reconstruction, AHandleWithoutASinkInItsPartIsRefused) {
  auto shape = make_shape(ShapeKind::Cactus, 16);
  shape.demo_constraints.fixed.clear();
  try {
    Deformer deformer(shape.mesh, shape.demo_constraints);
    FAIL() << "a handle with no sink was accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("the handle has no fixed vertex in its part of the mesh"), std::string::npos) << error.what();
  }
  // A region of interest supplies the sinks: the vertices outside it stay fixed.
  std::vector<int> around_the_arm;
  for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) {
    if (shape.mesh.positions(v, 0) < shape.mesh.positions.col(0).mean()) around_the_arm.push_back(static_cast<int>(v));
  }
  shape.demo_constraints.region_of_interest = around_the_arm;
  for (const int v : shape.demo_constraints.handles[0]) {
    if (std::find(around_the_arm.begin(), around_the_arm.end(), v) == around_the_arm.end()) shape.demo_constraints.region_of_interest.push_back(v);
  }
  EXPECT_NO_THROW(Deformer(shape.mesh, shape.demo_constraints));
}

TEST(Reconstruction, ResultsAreIndependentOfTheThreadCount) {
  auto shape = make_shape(ShapeKind::Cactus, 40);
  auto two_handles = shape.demo_constraints;
  std::vector<int> second;
  for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) {
    if (shape.mesh.positions(v, 2) > 0.85) second.push_back(static_cast<int>(v));  // the trunk's top
  }
  two_handles.handles.push_back(second);
  const std::vector<HandleTransform> transforms{shape.demo_transform, rigid(Eigen::Vector3d::UnitX(), 20.0, Eigen::Vector3d(0, 0.1, 0))};

  for (const bool several : {false, true}) {
    std::vector<Eigen::MatrixXd> results;
    for (const std::size_t threads : {1u, 2u, 4u}) {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      for (const auto schedule : {SolveSchedule::Blocked, SolveSchedule::ThreadGroups}) {
        Deformer deformer(shape.mesh, several ? two_handles : shape.demo_constraints, DeformerOptions::solver(SolverBackend::Eigen, schedule));
        Eigen::MatrixXd positions;
        deformer.deform(std::span(transforms.data(), several ? 2 : 1), positions);
        results.push_back(positions);
      }
    }
    for (const auto& result : results) EXPECT_EQ(result, results[0]) << (several ? "two handles" : "one handle");
    EXPECT_GT((results[0] - shape.mesh.positions).cwiseAbs().maxCoeff(), 0.05);
  }
}

TEST(Reconstruction, ConstrainedVerticesAreExactAndTheRestIsSmooth) {
  auto shape = make_shape(ShapeKind::Cylinder, 32);
  Deformer deformer(shape.mesh, shape.demo_constraints);
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&shape.demo_transform, 1), positions);
  for (const int v : shape.demo_constraints.fixed) EXPECT_EQ(positions.row(v), shape.mesh.positions.row(v));
  for (const int v : shape.demo_constraints.handles[0]) {
    EXPECT_EQ(positions.row(v).transpose(), shape.demo_transform.apply(shape.mesh.positions.row(v).transpose()));
  }
  // Detail preservation: edge lengths change little under a rigid handle motion.
  double worst = 0.0;
  for (Eigen::Index t = 0; t < shape.mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = shape.mesh.triangles(t, k), b = shape.mesh.triangles(t, (k + 1) % 3);
      const double before = (shape.mesh.positions.row(a) - shape.mesh.positions.row(b)).norm();
      const double after = (positions.row(a) - positions.row(b)).norm();
      worst = std::max(worst, std::abs(after / before - 1.0));
    }
  }
  EXPECT_LT(worst, 0.5);
}

TEST(Twist, SevenHundredTwentyDegreesGrowsMonotonicallyAlongTheBar) {
  auto shape = make_shape(ShapeKind::Bar, 32);  // 8 × 8 × 50 cells, z from 0 to 1
  const auto twist = HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero(), 4.0 * kPi);
  EXPECT_LE((twist.linear - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);  // the handle does not move
  Deformer deformer(shape.mesh, shape.demo_constraints);
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&twist, 1), positions);

  // Follow the bar's edge x = y = max from bottom to top and unwrap its angle about z.
  const double corner = shape.mesh.positions.col(0).maxCoeff();
  std::vector<std::pair<double, Eigen::Index>> edge;
  for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) {
    if (shape.mesh.positions(v, 0) == corner && shape.mesh.positions(v, 1) == corner) edge.emplace_back(shape.mesh.positions(v, 2), v);
  }
  std::sort(edge.begin(), edge.end());
  ASSERT_GT(edge.size(), 40u);
  const double rest_angle = std::atan2(corner, corner);
  double unwrapped = 0.0, previous_raw = 0.0;
  std::vector<double> angles;
  for (const auto& [z, v] : edge) {
    const double raw = std::atan2(positions(v, 1), positions(v, 0)) - rest_angle;
    if (!angles.empty()) {
      double step = raw - previous_raw;
      step -= 2.0 * kPi * std::round(step / (2.0 * kPi));
      unwrapped += step;
    } else {
      unwrapped = raw;
    }
    previous_raw = raw;
    angles.push_back(unwrapped);
  }
  for (std::size_t k = 1; k < angles.size(); ++k) EXPECT_GE(angles[k], angles[k - 1] - 1e-9) << "level " << k;
  EXPECT_NEAR(angles.front(), 0.0, 1e-9);
  EXPECT_NEAR(angles.back(), 4.0 * kPi, 1e-6);
  // A slerp would have seen the identity: the middle of the bar really turned, by about a full turn.
  EXPECT_NEAR(angles[angles.size() / 2], 2.0 * kPi, 0.6);
}

TEST(SeveralHandles, QuaternionFieldInterpolatesTheHandlesWithIdentityAtSinks) {
  auto shape = make_shape(ShapeKind::Cylinder, 32);
  EditConstraints constraints;
  std::vector<int> top, middle;
  for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) {
    const double z = shape.mesh.positions(v, 2);
    if (z < 0.05) constraints.fixed.push_back(static_cast<int>(v));
    if (z > 0.95) top.push_back(static_cast<int>(v));
    if (std::abs(z - 0.5) < 0.02) middle.push_back(static_cast<int>(v));
  }
  constraints.handles = {top, middle};
  // A rotation of more than half a turn: its quaternion is taken in the identity's hemisphere.
  Eigen::Matrix<double, 3, 4> affine;
  affine << Eigen::AngleAxisd(200.0 * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix(), Eigen::Vector3d(0, 0, 0.1);
  const std::vector<HandleTransform> transforms{HandleTransform::from_affine(affine),
                                                rigid(Eigen::Vector3d::UnitX(), 30.0, Eigen::Vector3d(0, 0.05, 0))};
  Deformer deformer(shape.mesh, constraints);
  const auto field = interpolate_field(deformer.system(), deformer.partition(), transforms);
  const auto& partition = deformer.partition();
  for (std::size_t v = 0; v < partition.role.size(); ++v) {
    const auto row = static_cast<Eigen::Index>(v);
    EXPECT_NEAR(field.rotation.row(row).norm(), 1.0, 1e-12);
    if (partition.role[v] == VertexRole::Fixed) {
      EXPECT_EQ(field.rotation.row(row), Eigen::RowVector4d(1, 0, 0, 0));
      EXPECT_EQ(field.scale(row), 1.0);
    }
    if (partition.role[v] == VertexRole::Handle) {
      const auto q = transforms[static_cast<std::size_t>(partition.handle_index[v])].rotation();
      EXPECT_LE((field.rotation.row(row) - Eigen::RowVector4d(q.w(), q.x(), q.y(), q.z())).cwiseAbs().maxCoeff(), 1e-12);
      // Same rotation as the handle's matrix (the sign flip changes nothing).
      EXPECT_LE((q.toRotationMatrix() - transforms[static_cast<std::size_t>(partition.handle_index[v])].linear).cwiseAbs().maxCoeff(), 1e-12);
    }
  }
  EXPECT_GE(field.rotation.col(0).minCoeff(), 0.0);  // aligned to the identity's hemisphere

  Eigen::MatrixXd positions;
  deformer.deform(transforms, positions);
  ASSERT_TRUE(positions.allFinite());
  for (std::size_t h = 0; h < 2; ++h) {
    for (const int v : constraints.handles[h]) EXPECT_EQ(positions.row(v).transpose(), transforms[h].apply(shape.mesh.positions.row(v).transpose()));
  }
  for (const int v : constraints.fixed) EXPECT_EQ(positions.row(v), shape.mesh.positions.row(v));
}

TEST(HandleTransform, PolarDecompositionSplitsRotationAndScale) {
  Eigen::Matrix<double, 3, 4> affine;
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
  affine << 1.5 * rotation, Eigen::Vector3d(1, 2, 3);
  const auto transform = HandleTransform::from_affine(affine);
  EXPECT_NEAR(transform.scale, 1.5, 1e-12);
  EXPECT_NEAR(transform.angle, 1.1, 1e-12);
  EXPECT_LE((transform.rotation().toRotationMatrix() - rotation).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((transform.at_fraction(0.0).linear - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(transform.at_fraction(1.0).linear, transform.linear);
  affine.leftCols<3>() = Eigen::Vector3d(1, 1, 0).asDiagonal();
  EXPECT_THROW(HandleTransform::from_affine(affine), InputError);  // singular
  affine.leftCols<3>() = Eigen::Vector3d(1, 1, -1).asDiagonal();
  EXPECT_THROW(HandleTransform::from_affine(affine), InputError);  // reflection
}

TEST(Deformer, RejectsContradictoryConstraints) {
  auto shape = make_shape(ShapeKind::Sphere, 16);
  auto constraints = shape.demo_constraints;
  constraints.fixed.push_back(constraints.handles[0][0]);
  EXPECT_THROW(Deformer(shape.mesh, constraints), InputError);
  constraints = shape.demo_constraints;
  constraints.handles.clear();
  EXPECT_THROW(Deformer(shape.mesh, constraints), InputError);
  constraints = shape.demo_constraints;
  constraints.handles.push_back({});
  EXPECT_THROW(Deformer(shape.mesh, constraints), InputError);
  constraints = shape.demo_constraints;
  constraints.fixed.push_back(static_cast<int>(shape.mesh.vertex_count()));
  EXPECT_THROW(Deformer(shape.mesh, constraints), InputError);
}

TEST(Deformer, RegionOfInterestLeavesTheOutsideInPlace) {
  auto shape = make_shape(ShapeKind::Cactus, 32);
  auto constraints = shape.demo_constraints;
  for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) {
    if (shape.mesh.positions(v, 1) < -0.05) constraints.region_of_interest.push_back(static_cast<int>(v));  // the left arm side
  }
  Deformer deformer(shape.mesh, constraints);
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&shape.demo_transform, 1), positions);
  for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) {
    if (shape.mesh.positions(v, 1) >= -0.05 && deformer.partition().role[static_cast<std::size_t>(v)] != VertexRole::Handle) {
      EXPECT_EQ(positions.row(v), shape.mesh.positions.row(v));
    }
  }
  EXPECT_LT(deformer.system().free_count(), shape.mesh.vertex_count() / 2);
}

}  // namespace
}  // namespace hdeform

namespace hdeform {
namespace {

// A re-selection reuses the mesh's weights and Laplacian: the result is the fresh set-up's, bit
// for bit, and the operators are shared, not copied.
TEST(Reselection, ReusedOperatorsGiveTheFreshResultBitForBit) {
  const auto shape = make_shape(ShapeKind::Cactus, 24);
  const Deformer first(shape.mesh, shape.demo_constraints);
  EditConstraints other = shape.demo_constraints;
  other.handles.front().resize(other.handles.front().size() / 2);  // a smaller stroke
  Deformer reused(shape.mesh, other, first.operators());
  Deformer fresh(shape.mesh, other);
  EXPECT_EQ(reused.operators().get(), first.operators().get());
  Eigen::MatrixXd a, b;
  reused.deform(std::span(&shape.demo_transform, 1), a);
  fresh.deform(std::span(&shape.demo_transform, 1), b);
  EXPECT_EQ(a, b);
  EXPECT_EQ(reused.field(), fresh.field());
  EXPECT_EQ(reused.refine(a, 5), fresh.refine(b, 5));
  EXPECT_EQ(a, b);
  const auto other_mesh = make_shape(ShapeKind::Cactus, 16);
  EXPECT_THROW(Deformer(other_mesh.mesh, other_mesh.demo_constraints, first.operators()), std::invalid_argument);
}

// A shared rest mesh is used where it is, not copied (the editor's set-ups share their document's
// mesh), and solves as a copy of it does, to the bit.
TEST(Deformer, ASharedRestMeshIsNotCopiedAndSolvesAsACopyDoes) {
  const auto shape = make_shape(ShapeKind::Cactus, 24);
  const auto rest = std::make_shared<const Mesh>(shape.mesh);
  Deformer shared(rest, shape.demo_constraints, nullptr);
  Deformer copied(shape.mesh, shape.demo_constraints);
  EXPECT_EQ(&shared.rest(), rest.get());
  EXPECT_NE(&copied.rest(), &shape.mesh);
  Eigen::MatrixXd a, b;
  shared.deform(std::span(&shape.demo_transform, 1), a);
  copied.deform(std::span(&shape.demo_transform, 1), b);
  EXPECT_EQ(a, b);
  EXPECT_EQ(shared.refine(a, 3), copied.refine(b, 3));
  EXPECT_EQ(a, b);
  EXPECT_THROW(Deformer(std::shared_ptr<const Mesh>(), shape.demo_constraints, nullptr), std::invalid_argument);
}

// The same free vertices on the same mesh (a handle vertex made fixed, say): L_ff's pattern is
// unchanged, so its analysis is taken from the last set-up; the result is the fresh one's.
TEST(Reselection, TheSameFreeVerticesReuseTheAnalysis) {
  const auto shape = make_shape(ShapeKind::Cactus, 24);
  const Deformer first(shape.mesh, shape.demo_constraints);
  EXPECT_FALSE(first.system().factor().reused_analysis());
  EditConstraints moved = shape.demo_constraints;
  moved.fixed.push_back(moved.handles.front().back());  // now fixed instead of handle
  moved.handles.front().pop_back();
  Deformer reused(shape.mesh, moved, first.operators());
  Deformer fresh(shape.mesh, moved);
  EXPECT_TRUE(reused.system().factor().reused_analysis());
  EXPECT_FALSE(fresh.system().factor().reused_analysis());
  Eigen::MatrixXd a, b;
  reused.deform(std::span(&shape.demo_transform, 1), a);
  fresh.deform(std::span(&shape.demo_transform, 1), b);
  EXPECT_EQ(a, b);
  // A different free set is analysed again.
  EditConstraints smaller = shape.demo_constraints;
  smaller.handles.front().resize(smaller.handles.front().size() / 2);
  EXPECT_FALSE(Deformer(shape.mesh, smaller, first.operators()).system().factor().reused_analysis());
}

}  // namespace
}  // namespace hdeform

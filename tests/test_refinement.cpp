// As-rigid-as-possible refinement (refinement.h): the rotation fit against an SVD, and the
// iterations against the energy written out here from its definition, a global step solved densely
// here, and a minimisation (L-BFGS) that shares nothing with the local/global scheme.
#include <tbb/global_control.h>

#include <Eigen/Dense>
#include <complex>
#include <map>
#include <numbers>
#include <random>
#include <span>
#include <stdexcept>

#include "hdeform/deformer.h"
#include "hdeform/laplacian.h"
#include "hdeform/rotation_fit.h"
#include "hdeform/shape_metrics.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Matrix3d random_rotation(std::mt19937& random) {
  std::normal_distribution<double> normal;
  return Eigen::Quaterniond(normal(random), normal(random), normal(random), normal(random)).normalized().toRotationMatrix();
}

TEST(RotationFit, MatchesTheSvdFromAnyStartAndKeepsImproving) {
  std::mt19937 random(3);
  std::normal_distribution<double> normal;
  int checked = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    Eigen::Matrix3d a;
    for (double& value : a.reshaped()) value = normal(random);
    if (trial % 4 == 1) a.col(2) = 0.5 * a.col(0) - a.col(1);  // rank 2, as a flat neighbourhood gives
    const Eigen::Matrix3d expected = closest_rotation_svd(a);
    const Eigen::Matrix3d start = trial % 3 == 0 ? Eigen::Matrix3d(random_rotation(random)) : Eigen::Matrix3d(Eigen::Matrix3d::Identity());
    const RotationFit fit = fit_rotation(a, start, 1e-10, 64);
    EXPECT_NEAR((fit.rotation.transpose() * fit.rotation - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
    EXPECT_NEAR(fit.rotation.determinant(), 1.0, 1e-12);
    EXPECT_NEAR((fit.rotation - expected).norm(), 0.0, 1e-8) << "trial " << trial << "\n" << a;
    // One step from anywhere never lowers the objective.
    const RotationFit one = fit_rotation(a, start, 1e-10, 1);
    EXPECT_GE(one.objective, (start.array() * a.array()).sum() - 1e-12);
    ++checked;
  }
  EXPECT_EQ(checked, 2000);
}

TEST(RotationFit, StartsAtSaddlesAndHalfTurnsAndDegenerateMatrices) {
  const Eigen::Matrix3d stretch = Eigen::Vector3d(3.0, 2.0, 1.0).asDiagonal();
  // Starting a half turn away about each axis: the gradient vanishes there, and the fit must not stop.
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Matrix3d half_turn = Eigen::AngleAxisd(kPi, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
    const RotationFit fit = fit_rotation(stretch, half_turn);
    EXPECT_NEAR((fit.rotation - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-9) << "axis " << axis;
  }
  const RotationFit zero = fit_rotation(Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Identity());
  EXPECT_TRUE(zero.rotation.allFinite());
  EXPECT_NEAR(zero.rotation.determinant(), 1.0, 1e-12);
}

// Many fits at once (four in SIMD lanes) against one at a time: the same bits, whatever the kinds
// of matrix side by side in one group (a lane that converges in one step beside one that needs
// many, or one that falls back to the SVD), and whatever the grouping.
TEST(RotationFit, ManyAtOnceGiveWhatEachGivesAlone) {
  std::mt19937 random(11);
  std::normal_distribution<double> normal;
  std::uniform_int_distribution<int> kind_of(0, 6);
  std::vector<Eigen::Matrix3d> a, start;
  for (int trial = 0; trial < 4001; ++trial) {  // not a multiple of four: a tail of one
    Eigen::Matrix3d m;
    for (double& value : m.reshaped()) value = normal(random);
    const Eigen::Matrix3d turn = random_rotation(random);
    switch (kind_of(random)) {
      case 0: break;                                                    // random
      case 1: m.col(2) = 0.5 * m.col(0) - m.col(1); break;              // rank 2 (a flat neighbourhood)
      case 2: m = m.col(0) * m.col(1).transpose(); break;               // rank 1
      case 3: m *= 1e-12; break;                                        // tiny
      case 4: m = turn * Eigen::Vector3d(3.0, 2.0, -1e-9).asDiagonal(); break;  // nearly singular, det < 0
      case 5: m = turn + 1e-3 * m; break;                               // nearly the warm start: one short step
      case 6: m.setZero(); break;
    }
    a.push_back(m);
    start.push_back(trial % 5 == 4 ? Eigen::Matrix3d(random_rotation(random)) : turn);
  }
  int fell_back = 0, converged_at_once = 0, long_runs = 0;
  for (const int max_steps : {0, 1, 2, 16, 64}) {
    for (const double tolerance : {1e-7, 1e-12}) {
      std::vector<RotationFit> together(a.size());
      fit_rotations(a, start, together, tolerance, max_steps);
      for (std::size_t i = 0; i < a.size(); ++i) {
        const RotationFit alone = fit_rotation(a[i], start[i], tolerance, max_steps);
        ASSERT_LE((together[i].rotation - alone.rotation).cwiseAbs().maxCoeff(), 1e-12) << "matrix " << i << ", " << max_steps << " steps";
        ASSERT_NEAR(together[i].objective, alone.objective, 1e-12 * (1.0 + std::abs(alone.objective))) << "matrix " << i;
        ASSERT_EQ(together[i].steps, alone.steps) << "matrix " << i;
        ASSERT_EQ(together[i].fell_back_to_svd, alone.fell_back_to_svd) << "matrix " << i;
        fell_back += alone.fell_back_to_svd ? 1 : 0;
        converged_at_once += alone.steps == 1 && max_steps > 1 ? 1 : 0;
        long_runs += alone.steps > 3 ? 1 : 0;
      }
      // Shifted by one, every matrix has other neighbours in its lanes: still the same bits.
      std::vector<RotationFit> shifted(a.size() - 1);
      fit_rotations(std::span(a).subspan(1), std::span(start).subspan(1), shifted, tolerance, max_steps);
      for (std::size_t i = 1; i < a.size(); ++i) {
        ASSERT_EQ(shifted[i - 1].rotation, together[i].rotation) << "matrix " << i;
        ASSERT_EQ(shifted[i - 1].objective, together[i].objective) << "matrix " << i;
      }
    }
  }
  // The groups did mix every way a lane can end.
  EXPECT_GT(fell_back, 100);
  EXPECT_GT(converged_at_once, 100);
  EXPECT_GT(long_runs, 100);
  std::vector<RotationFit> too_few(2);
  EXPECT_THROW(fit_rotations(a, start, too_few), std::invalid_argument);
}

// The energy of refinement.h written out from its definition, vertex by vertex, with rotations
// fitted by SVD: for every vertex with a free neighbour triangle, every triangle around it, every
// edge of that triangle.
struct ReferenceArap {
  const Mesh& rest;
  CotangentWeights weights;
  std::vector<int> free;          // per vertex: 1 when free
  std::vector<int> energy_vertex; // corners of triangles with a free corner
  std::vector<double> scale;      // per triangle
  std::vector<std::vector<int>> around;  // per vertex: its triangles

  ReferenceArap(const Mesh& mesh, const Deformer& deformer, const std::vector<double>& scales = {})
      : rest(mesh), weights(cotangent_weights(mesh)) {
    around.resize(static_cast<std::size_t>(mesh.vertex_count()));
    for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
      if (weights.kind[static_cast<std::size_t>(t)] == ElementKind::Ignored) continue;
      for (int k = 0; k < 3; ++k) around[static_cast<std::size_t>(mesh.triangles(t, k))].push_back(static_cast<int>(t));
    }
    free.assign(static_cast<std::size_t>(mesh.vertex_count()), 0);
    for (const int v : deformer.partition().free_vertices) free[static_cast<std::size_t>(v)] = 1;
    std::vector<int> marked(static_cast<std::size_t>(mesh.vertex_count()), 0);
    for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
      if (weights.kind[static_cast<std::size_t>(t)] == ElementKind::Ignored) continue;
      bool any_free = false;
      for (int k = 0; k < 3; ++k) any_free |= free[static_cast<std::size_t>(mesh.triangles(t, k))] != 0;
      if (!any_free) continue;
      for (int k = 0; k < 3; ++k) marked[static_cast<std::size_t>(mesh.triangles(t, k))] = 1;
    }
    for (std::size_t v = 0; v < marked.size(); ++v) {
      if (marked[v]) energy_vertex.push_back(static_cast<int>(v));
    }
    scale = scales.empty() ? std::vector<double>(static_cast<std::size_t>(mesh.triangle_count()), 1.0) : scales;
  }

  template <class Visit>  // visit(triangle, a, b, weight) for each edge ab of each triangle around v
  void for_each_edge_around(int v, Visit&& visit) const {
    for (const int t : around[static_cast<std::size_t>(v)]) {
      for (int k = 0; k < 3; ++k) visit(t, rest.triangles(t, (k + 1) % 3), rest.triangles(t, (k + 2) % 3), weights.half_cotangent(t, k));
    }
  }

  Eigen::Matrix3d rotation(int v, const Eigen::MatrixXd& p) const {
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for_each_edge_around(v, [&](Eigen::Index t, int a, int b, double w) {
      covariance += w * scale[static_cast<std::size_t>(t)] * (p.row(a) - p.row(b)).transpose() * (rest.positions.row(a) - rest.positions.row(b));
    });
    return closest_rotation_svd(covariance);
  }

  double energy(const Eigen::MatrixXd& p) const {
    double total = 0.0;
    for (const int v : energy_vertex) {
      const Eigen::Matrix3d r = rotation(v, p);
      for_each_edge_around(v, [&](Eigen::Index t, int a, int b, double w) {
        const Eigen::Vector3d rest_edge = (rest.positions.row(a) - rest.positions.row(b)).transpose();
        total += w * ((p.row(a) - p.row(b)).transpose() - scale[static_cast<std::size_t>(t)] * r * rest_edge).squaredNorm();
      });
    }
    return total;
  }

  // ∂E/∂p at the rotations fitted to p (they are optimal, so they do not move the derivative).
  Eigen::MatrixXd gradient(const Eigen::MatrixXd& p) const {
    std::vector<Eigen::Matrix3d> rotations(static_cast<std::size_t>(rest.vertex_count()), Eigen::Matrix3d::Zero());
    for (const int v : energy_vertex) rotations[static_cast<std::size_t>(v)] = rotation(v, p);
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(p.rows(), 3);
    for (const int v : energy_vertex) {
      for_each_edge_around(v, [&](Eigen::Index t, int a, int b, double w) {
        const Eigen::Vector3d rest_edge = (rest.positions.row(a) - rest.positions.row(b)).transpose();
        const Eigen::Vector3d residual =
            (p.row(a) - p.row(b)).transpose() - scale[static_cast<std::size_t>(t)] * rotations[static_cast<std::size_t>(v)] * rest_edge;
        g.row(a) += 2.0 * w * residual.transpose();
        g.row(b) -= 2.0 * w * residual.transpose();
      });
    }
    for (Eigen::Index v = 0; v < p.rows(); ++v) {
      if (!free[static_cast<std::size_t>(v)]) g.row(v).setZero();
    }
    return g;
  }
};

// The cylinder of the demo, its top dragged sideways (no rotation: what the paper cannot bend).
struct Drag {
  Shape shape = make_shape(ShapeKind::Cylinder, 12);
  HandleTransform sideways = HandleTransform::from_affine((Eigen::Matrix<double, 3, 4>() << 1, 0, 0, 0.4, 0, 1, 0, 0, 0, 0, 1, -0.15).finished());
};

DeformerOptions refined(bool accelerate = true, double tolerance = 1e-6) {
  DeformerOptions options;
  options.prepare_refinement = true;
  options.refinement.accelerate = accelerate;
  options.refinement.tolerance = tolerance;
  return options;
}

TEST(Refinement, ThePlainIterationNeverRaisesTheEnergyAndAccelerationEndsLower) {
  const Drag drag;
  std::vector<double> energies[2];
  for (const bool accelerate : {false, true}) {
    Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, refined(accelerate, 1e-15));
    Eigen::MatrixXd positions;
    deformer.deform(std::span(&drag.sideways, 1), positions);
    deformer.refine(positions, 0);  // begins the edit: the paper's result and its energy
    auto& energy = energies[accelerate ? 1 : 0];
    energy.push_back(deformer.refinement_status().unrefined_energy);
    for (int k = 0; k < 40; ++k) {
      if (deformer.refine(positions, 1) == 0) break;  // converged to rounding (the accelerated run does)
      energy.push_back(deformer.refinement_status().energy);
    }
  }
  ASSERT_EQ(energies[0].size(), 41u);  // the plain run takes all 40
  for (std::size_t k = 1; k < energies[0].size(); ++k) {
    EXPECT_LE(energies[0][k], energies[0][k - 1] * (1.0 + 1e-12)) << "plain iteration " << k;
  }
  EXPECT_LT(energies[0].back(), 0.5 * energies[0].front());  // it does bend
  EXPECT_LE(energies[1].back(), energies[0][energies[1].size() - 1]);  // at the same count
  EXPECT_LE(energies[1].back(), energies[0].back());
  // The safeguard keeps the accelerated run monotonic too.
  for (std::size_t k = 1; k < energies[1].size(); ++k) EXPECT_LE(energies[1][k], energies[1][k - 1] * (1.0 + 1e-12)) << k;
}

TEST(Refinement, TheReportedEnergyIsTheEnergyOfItsDefinition) {
  const Drag drag;
  Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, refined());
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&drag.sideways, 1), positions);
  EXPECT_EQ(deformer.refine(positions, 0), 0);
  const ReferenceArap reference(drag.shape.mesh, deformer);
  EXPECT_NEAR(deformer.refinement_status().unrefined_energy, reference.energy(positions), 1e-9 * reference.energy(positions));
  deformer.refine(positions, 200);
  ASSERT_TRUE(deformer.refinement_status().converged);
  EXPECT_NEAR(deformer.refinement_status().energy, reference.energy(positions), 1e-6 * reference.energy(positions));
}

TEST(Refinement, NothingMovedHasZeroEnergyAndStaysAtRest) {
  const Drag drag;
  Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, refined());
  Eigen::MatrixXd positions;
  const HandleTransform identity = HandleTransform::identity();
  deformer.deform(std::span(&identity, 1), positions);
  const Eigen::MatrixXd paper = positions;
  EXPECT_EQ(deformer.refine(positions, 10), 0);  // converged before any iteration
  EXPECT_TRUE(deformer.refinement_status().converged);
  EXPECT_EQ(positions, paper);  // the paper's result (the rest shape to rounding), untouched
  // Zero up to the rounding of sums of terms of the size of the rest edges' Σ w‖e‖².
  double scale = 0.0;
  const auto weights = cotangent_weights(drag.shape.mesh);
  for (Eigen::Index t = 0; t < drag.shape.mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      scale += std::abs(weights.half_cotangent(t, k)) *
               (drag.shape.mesh.positions.row(drag.shape.mesh.triangles(t, (k + 1) % 3)) - drag.shape.mesh.positions.row(drag.shape.mesh.triangles(t, (k + 2) % 3))).squaredNorm();
    }
  }
  EXPECT_LE(std::abs(deformer.refinement_status().energy), 1e-12 * scale);
  EXPECT_LE((positions - drag.shape.mesh.positions).cwiseAbs().maxCoeff(), 1e-12);
  // ... also after a bent edit (reset to rest: nothing to refine).
  deformer.deform(std::span(&drag.sideways, 1), positions);
  deformer.refine(positions, 30);
  deformer.deform(std::span(&identity, 1), positions);
  EXPECT_EQ(deformer.refine(positions, 10), 0);
  EXPECT_LE((positions - drag.shape.mesh.positions).cwiseAbs().maxCoeff(), 1e-12);
}

// The handle of the drag moved sideways by `x` (in the drag's own direction, x = 1 its full length).
HandleTransform sideways_by(const Drag& drag, double x) {
  Eigen::Matrix<double, 3, 4> affine = Eigen::Matrix<double, 3, 4>::Zero();
  affine.leftCols<3>().setIdentity();
  affine.col(3) = x * drag.sideways.translation;
  return HandleTransform::from_affine(affine);
}

// A pose's refined shape and both its energies are a function of the pose: a Deformer driven
// through a drag that reverses past the rest shape (the editor's reproduction, in the library)
// gives, at each pose, the same bits as a fresh Deformer given that pose alone.
TEST(Refinement, EachPoseGivesTheSameBitsAsAFreshDeformerWhateverCameBefore) {
  const Drag drag;
  Deformer driven(drag.shape.mesh, drag.shape.demo_constraints, refined());
  Eigen::MatrixXd positions;
  for (const double x : {0.5, 1.0, 0.5, 0.0, -0.5, 1.0}) {
    SCOPED_TRACE("x = " + std::to_string(x));
    const HandleTransform pose = sideways_by(drag, x);
    driven.deform(std::span(&pose, 1), positions);
    driven.refine(positions, 1000);
    Deformer fresh(drag.shape.mesh, drag.shape.demo_constraints, refined());
    Eigen::MatrixXd expected;
    fresh.deform(std::span(&pose, 1), expected);
    fresh.refine(expected, 1000);
    EXPECT_EQ(positions, expected);
    EXPECT_EQ(driven.refinement_status().unrefined_energy, fresh.refinement_status().unrefined_energy);
    EXPECT_EQ(driven.refinement_status().energy, fresh.refinement_status().energy);
    EXPECT_EQ(driven.refinement_status().iterations, fresh.refinement_status().iterations);
    EXPECT_TRUE(driven.refinement_status().converged);
    if (x != 0.0) {
      EXPECT_GT(driven.refinement_status().iterations, 3) << "a bend takes more than a few iterations";
    }
  }
}

// Iterations that a caller does not show (the editor's, between two frames of a settling shape)
// leave the positions alone; written afterwards, they are what refine() writes, to the last bit.
TEST(Refinement, IterationsLeftUnwrittenAreWrittenWithTheBitsOfRefine) {
  const Drag drag;
  const HandleTransform pose = sideways_by(drag, 1.0);
  Deformer unwritten(drag.shape.mesh, drag.shape.demo_constraints, refined()), written(drag.shape.mesh, drag.shape.demo_constraints, refined());
  Eigen::MatrixXd positions, expected;
  unwritten.deform(std::span(&pose, 1), positions);
  written.deform(std::span(&pose, 1), expected);
  const Eigen::MatrixXd papers = positions;
  unwritten.write_refined(positions);
  EXPECT_EQ(positions, papers) << "nothing refined yet: nothing to write";
  for (const int run : {3, 2, 1}) {
    SCOPED_TRACE("a run of " + std::to_string(run));
    const Eigen::MatrixXd before = positions;
    ASSERT_EQ(unwritten.refine_unwritten(positions, run), run);
    EXPECT_EQ(positions, before);
    ASSERT_EQ(written.refine(expected, run), run);
    ASSERT_NE(expected, before);
    unwritten.write_refined(positions);
    EXPECT_EQ(positions, expected);
    EXPECT_EQ(unwritten.refinement_status().energy, written.refinement_status().energy);
  }
  // A new edit: nothing refined since, nothing written.
  unwritten.deform(std::span(&pose, 1), positions);
  const Eigen::MatrixXd again = positions;
  unwritten.write_refined(positions);
  EXPECT_EQ(positions, again);
}

// A start from the last edit (a drag shown live) reports the pose's own unrefined energy, and one
// that does worse than the paper's result goes on from there to where a fresh run goes: it is
// never taken for converged.
TEST(Refinement, AStartFromTheLastEditThatDoesWorseGoesOnFromThePapersResult) {
  const Drag drag;
  Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, refined(true, 1e-10));
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&drag.sideways, 1), positions);
  deformer.refine(positions, 200);
  EXPECT_FALSE(deformer.refinement_status().started_from_paper);  // a first edit starts from the paper
  // Back past the rest shape: the bent rotations are a poor start, the paper's result a good one.
  const HandleTransform back = sideways_by(drag, -0.5);
  deformer.deform(std::span(&back, 1), positions, RefinementStart::FromLastEdit);
  EXPECT_EQ(deformer.refine(positions, 1), 1);
  EXPECT_TRUE(deformer.refinement_status().started_from_paper);
  EXPECT_FALSE(deformer.refinement_status().converged) << "falling back to the paper's result is not converging";
  deformer.refine(positions, 1000);
  ASSERT_TRUE(deformer.refinement_status().converged);

  Deformer fresh(drag.shape.mesh, drag.shape.demo_constraints, refined(true, 1e-10));
  Eigen::MatrixXd expected;
  fresh.deform(std::span(&back, 1), expected);
  fresh.refine(expected, 1000);
  EXPECT_EQ(deformer.refinement_status().unrefined_energy, fresh.refinement_status().unrefined_energy);
  EXPECT_NEAR(deformer.refinement_status().energy, fresh.refinement_status().energy, 1e-6 * fresh.refinement_status().energy);
  EXPECT_LE((positions - expected).cwiseAbs().maxCoeff(), 1e-4 * bounding_box_diagonal(drag.shape.mesh.positions));
  EXPECT_LT(fresh.refinement_status().energy, 0.8 * fresh.refinement_status().unrefined_energy);

  // A small step onwards from the bent shape keeps the start from the last edit, and its
  // unrefined energy is still the pose's own.
  deformer.deform(std::span(&drag.sideways, 1), positions);
  deformer.refine(positions, 200);
  const HandleTransform further = drag.sideways.at_fraction(1.02);
  deformer.deform(std::span(&further, 1), positions, RefinementStart::FromLastEdit);
  deformer.refine(positions, 1);
  EXPECT_FALSE(deformer.refinement_status().started_from_paper);
  EXPECT_LT(deformer.refinement_status().energy, deformer.refinement_status().unrefined_energy);
  Deformer further_fresh(drag.shape.mesh, drag.shape.demo_constraints, refined(true, 1e-10));
  further_fresh.deform(std::span(&further, 1), expected);
  further_fresh.refine(expected, 0);
  EXPECT_EQ(deformer.refinement_status().unrefined_energy, further_fresh.refinement_status().unrefined_energy);
}

// The settle test stops at the first iteration from whose state a plain iteration would move no
// vertex by more than the fraction of the diagonal; largest_step is that move, as measured here.
TEST(Refinement, TheSettleTestStopsAtTheFirstSmallPlainStep) {
  const Drag drag;
  const double diagonal = bounding_box_diagonal(drag.shape.mesh.positions);
  // The first iteration of a run is a plain one (nothing to mix yet): its move is largest_step.
  {
    Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, refined());
    Eigen::MatrixXd positions;
    deformer.deform(std::span(&drag.sideways, 1), positions);
    const Eigen::MatrixXd paper = positions;
    ASSERT_EQ(deformer.refine(positions, 1), 1);
    EXPECT_NEAR(deformer.refinement_status().largest_step, (positions - paper).rowwise().norm().maxCoeff() / diagonal, 1e-12);
    EXPECT_GT(deformer.refinement_status().largest_step, 1e-3);
  }
  // Without the settle test: the steps of a long run, iteration by iteration.
  std::vector<double> steps;
  {
    Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, refined(true, 1e-15));
    Eigen::MatrixXd positions;
    deformer.deform(std::span(&drag.sideways, 1), positions);
    for (int k = 0; k < 300 && deformer.refine(positions, 1) == 1; ++k) steps.push_back(deformer.refinement_status().largest_step);
  }
  for (const double settle : {1e-3, 1e-4, 1e-5}) {
    const auto first_small = std::find_if(steps.begin(), steps.end(), [&](double step) { return step <= settle; });
    ASSERT_NE(first_small, steps.end()) << settle;
    DeformerOptions options = refined(true, 1e-15);
    options.refinement.settle = settle;
    Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, options);
    Eigen::MatrixXd positions;
    deformer.deform(std::span(&drag.sideways, 1), positions);
    deformer.refine(positions, 1000);
    EXPECT_TRUE(deformer.refinement_status().converged);
    EXPECT_TRUE(deformer.refinement_status().settled);
    EXPECT_EQ(deformer.refinement_status().iterations, first_small - steps.begin() + 1) << settle;
  }
}

TEST(Refinement, ConstrainedVerticesStayExactlyAtTheirTargets) {
  const Drag drag;
  Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, refined());
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&drag.sideways, 1), positions);
  deformer.refine(positions, 50);
  for (const int v : drag.shape.demo_constraints.fixed) EXPECT_EQ(positions.row(v), drag.shape.mesh.positions.row(v));
  for (const int v : drag.shape.demo_constraints.handles[0]) {
    EXPECT_EQ(positions.row(v).transpose(), drag.sideways.apply(drag.shape.mesh.positions.row(v).transpose()));
  }
}

TEST(Refinement, ARigidlyMovedCopyGivesTheResultMovedAlike) {
  const Drag drag;
  const Eigen::Matrix3d q = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  const Eigen::Vector3d d(0.3, -1.2, 2.0);
  Mesh moved = drag.shape.mesh;
  moved.positions = (drag.shape.mesh.positions * q.transpose()).rowwise() + d.transpose();
  // T' = M T M⁻¹ for M = (q, d).
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity(), t = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = q;
  m.topRightCorner<3, 1>() = d;
  t.topRows<3>() = drag.sideways.affine();
  const Eigen::Matrix4d conjugated = m * t * m.inverse();
  const HandleTransform moved_transform = HandleTransform::from_affine(conjugated.topRows<3>());

  Eigen::MatrixXd original, copy;
  Deformer first(drag.shape.mesh, drag.shape.demo_constraints, refined(true, 1e-15));
  first.deform(std::span(&drag.sideways, 1), original);
  first.refine(original, 25);
  Deformer second(moved, drag.shape.demo_constraints, refined(true, 1e-15));
  second.deform(std::span(&moved_transform, 1), copy);
  second.refine(copy, 25);
  const Eigen::MatrixXd expected = (original * q.transpose()).rowwise() + d.transpose();
  EXPECT_LE((copy - expected).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT((original - drag.shape.mesh.positions).cwiseAbs().maxCoeff(), 0.1);
}

// At convergence the positions are the global step of the rotations fitted to them, solved here
// densely, and the energy is that of a minimisation that shares nothing with local/global.
TEST(Refinement, ConvergesToAFixedPointAndToTheMinimumOfAnIndependentSolver) {
  const Drag drag;
  const Mesh& mesh = drag.shape.mesh;
  Deformer deformer(mesh, drag.shape.demo_constraints, refined(true, 1e-15));
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&drag.sideways, 1), positions);
  const Eigen::MatrixXd paper = positions;
  deformer.refine(positions, 3000);
  const ReferenceArap reference(mesh, deformer);

  // Fixed point: L_ff x_f = b_f − L_fc x_c with b_i = Σ_t Σ_b w_ib (R_a+R_b+R_c)/3 (p_i − p_b).
  std::vector<Eigen::Matrix3d> rotations(static_cast<std::size_t>(mesh.vertex_count()), Eigen::Matrix3d::Identity());
  for (const int v : reference.energy_vertex) rotations[static_cast<std::size_t>(v)] = reference.rotation(v, positions);
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(mesh.vertex_count(), 3);
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    const Eigen::Matrix3d map = (rotations[static_cast<std::size_t>(mesh.triangles(t, 0))] + rotations[static_cast<std::size_t>(mesh.triangles(t, 1))] +
                                 rotations[static_cast<std::size_t>(mesh.triangles(t, 2))]) / 3.0;
    for (int k = 0; k < 3; ++k) {
      const int i = mesh.triangles(t, k), next = mesh.triangles(t, (k + 1) % 3), previous = mesh.triangles(t, (k + 2) % 3);
      const Eigen::Vector3d g = reference.weights.half_cotangent(t, (k + 2) % 3) * (mesh.positions.row(i) - mesh.positions.row(next)).transpose() +
                                reference.weights.half_cotangent(t, (k + 1) % 3) * (mesh.positions.row(i) - mesh.positions.row(previous)).transpose();
      b.row(i) += (map * g).transpose();
    }
  }
  const Eigen::MatrixXd laplacian = Eigen::MatrixXd(cotangent_laplacian(mesh));
  const auto& free = deformer.partition().free_vertices;
  const auto f = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd lff(f, f), rhs(f, 3);
  for (Eigen::Index r = 0; r < f; ++r) {
    rhs.row(r) = b.row(free[static_cast<std::size_t>(r)]);
    for (Eigen::Index c = 0; c < f; ++c) lff(r, c) = laplacian(free[static_cast<std::size_t>(r)], free[static_cast<std::size_t>(c)]);
    for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
      if (!reference.free[static_cast<std::size_t>(v)]) rhs.row(r) -= laplacian(free[static_cast<std::size_t>(r)], v) * positions.row(v);
    }
  }
  const Eigen::MatrixXd step = lff.ldlt().solve(rhs);
  double worst = 0.0;
  for (Eigen::Index r = 0; r < f; ++r) worst = std::max(worst, (step.row(r) - positions.row(free[static_cast<std::size_t>(r)])).cwiseAbs().maxCoeff());
  EXPECT_LE(worst, 1e-7 * bounding_box_diagonal(mesh.positions));

  // L-BFGS on E(x) = min_R E(x, R) from the paper's result, with a backtracking line search.
  Eigen::MatrixXd x = paper;
  const auto flatten = [&](const Eigen::MatrixXd& full) {
    Eigen::VectorXd out(3 * f);
    for (Eigen::Index r = 0; r < f; ++r) out.segment<3>(3 * r) = full.row(free[static_cast<std::size_t>(r)]).transpose();
    return out;
  };
  const auto place = [&](const Eigen::VectorXd& flat, Eigen::MatrixXd& full) {
    for (Eigen::Index r = 0; r < f; ++r) full.row(free[static_cast<std::size_t>(r)]) = flat.segment<3>(3 * r).transpose();
  };
  std::vector<Eigen::VectorXd> s_history, y_history;
  double energy = reference.energy(x);
  Eigen::VectorXd gradient = flatten(reference.gradient(x));
  for (int iteration = 0; iteration < 1000; ++iteration) {
    Eigen::VectorXd direction = -gradient;
    std::vector<double> alphas;
    for (std::size_t k = s_history.size(); k-- > 0;) {
      const double alpha = s_history[k].dot(direction) / y_history[k].dot(s_history[k]);
      alphas.push_back(alpha);
      direction -= alpha * y_history[k];
    }
    if (!s_history.empty()) direction *= s_history.back().dot(y_history.back()) / y_history.back().squaredNorm();
    for (std::size_t k = 0; k < s_history.size(); ++k) {
      const double beta = y_history[k].dot(direction) / y_history[k].dot(s_history[k]);
      direction += s_history[k] * (alphas[s_history.size() - 1 - k] - beta);
    }
    double step_length = s_history.empty() ? 1e-3 / std::max(1e-12, gradient.norm()) : 1.0;
    Eigen::MatrixXd trial = x;
    const Eigen::VectorXd start = flatten(x);
    double trial_energy = 0.0;
    for (int halving = 0; halving < 60; ++halving, step_length *= 0.5) {
      place(start + step_length * direction, trial);
      trial_energy = reference.energy(trial);
      if (trial_energy <= energy + 1e-4 * step_length * gradient.dot(direction)) break;
    }
    if (!(trial_energy < energy)) break;  // no descent left: converged to rounding
    const Eigen::VectorXd next_gradient = flatten(reference.gradient(trial));
    const Eigen::VectorXd s_step = flatten(trial) - start, y_step = next_gradient - gradient;
    if (s_step.dot(y_step) > 1e-12 * s_step.norm() * y_step.norm()) {  // curvature pairs only where positive
      s_history.push_back(s_step);
      y_history.push_back(y_step);
    }
    if (s_history.size() > 10) {
      s_history.erase(s_history.begin());
      y_history.erase(y_history.begin());
    }
    x = trial;
    energy = trial_energy;
    gradient = next_gradient;
  }
  const double refined_energy = reference.energy(positions);
  EXPECT_NEAR(refined_energy, energy, 1e-6 * energy) << "refined " << refined_energy << ", L-BFGS " << energy;
  EXPECT_LT(energy, 0.5 * reference.energy(paper));
}

TEST(Refinement, TheSameBitsForAnyNumberOfThreads) {
  const Drag drag;
  Eigen::MatrixXd results[2];
  for (const int threads : {1, 2}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    Deformer deformer(drag.shape.mesh, drag.shape.demo_constraints, refined());
    Eigen::MatrixXd& positions = results[threads - 1];
    deformer.deform(std::span(&drag.sideways, 1), positions);
    deformer.refine(positions, 30);
  }
  EXPECT_EQ(results[0], results[1]);
}

TEST(Refinement, ADragSettlesToTheSameShapeAsOneJump) {
  const Drag drag;
  Deformer jump(drag.shape.mesh, drag.shape.demo_constraints, refined(true, 1e-15));
  Eigen::MatrixXd jumped, dragged;
  jump.deform(std::span(&drag.sideways, 1), jumped);
  jump.refine(jumped, 2000);
  Deformer steps(drag.shape.mesh, drag.shape.demo_constraints, refined(true, 1e-15));
  for (int step = 1; step <= 8; ++step) {
    const HandleTransform at = drag.sideways.at_fraction(step / 8.0);
    steps.deform(std::span(&at, 1), dragged, RefinementStart::FromLastEdit);
    steps.refine(dragged, 3);
  }
  steps.refine(dragged, 2000);
  EXPECT_LE((jumped - dragged).cwiseAbs().maxCoeff(), 1e-5 * bounding_box_diagonal(drag.shape.mesh.positions));
  EXPECT_LT(mean_edge_strain(drag.shape.mesh, jumped), mean_edge_strain(drag.shape.mesh, [&] {
              Eigen::MatrixXd paper;
              jump.deform(std::span(&drag.sideways, 1), paper);
              return paper;
            }()));
}

// Several handles (their rotations interpolated as quaternions) and a region of interest smaller
// than the mesh: the refinement lowers the energy of its definition, keeps every constraint and
// leaves the outside alone.
TEST(Refinement, SeveralHandlesAndARegionOfInterest) {
  const Drag drag;
  const Mesh& mesh = drag.shape.mesh;
  EditConstraints constraints = drag.shape.demo_constraints;
  // Split the top ring into two handles by x; keep only the upper part of the cylinder free.
  std::vector<int> left, right;
  for (const int v : constraints.handles[0]) (mesh.positions(v, 0) < 0.0 ? left : right).push_back(v);
  constraints.handles = {left, right};
  const double bottom = mesh.positions.col(2).minCoeff(), top = mesh.positions.col(2).maxCoeff();
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.positions(v, 2) > bottom + 0.3 * (top - bottom)) constraints.region_of_interest.push_back(static_cast<int>(v));
  }
  constraints.fixed.clear();  // the boundary of the region holds the rest
  const std::vector<HandleTransform> transforms{drag.sideways, drag.sideways.at_fraction(0.6)};
  Deformer deformer(mesh, constraints, refined(true, 1e-10));
  Eigen::MatrixXd positions;
  deformer.deform(transforms, positions);
  deformer.refine(positions, 0);
  const ReferenceArap reference(mesh, deformer);
  const double paper = reference.energy(positions);
  EXPECT_NEAR(deformer.refinement_status().unrefined_energy, paper, 1e-9 * paper);
  deformer.refine(positions, 500);
  EXPECT_LT(reference.energy(positions), 0.8 * paper);
  EXPECT_NEAR(deformer.refinement_status().energy, reference.energy(positions), 1e-6 * paper);
  for (std::size_t h = 0; h < 2; ++h) {
    for (const int v : constraints.handles[h]) EXPECT_EQ(positions.row(v).transpose(), transforms[h].apply(mesh.positions.row(v).transpose()));
  }
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    if (deformer.partition().role[static_cast<std::size_t>(v)] == VertexRole::Fixed) {
      EXPECT_EQ(positions.row(v), mesh.positions.row(v)) << v;
    }
  }
}

TEST(Refinement, ThePapersMultiTurnTwistKeepsItsTurns) {
  auto shape = make_shape(ShapeKind::Bar, 32);
  const auto twist = HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero(), 4.0 * kPi);
  Deformer deformer(shape.mesh, shape.demo_constraints, refined(true, 1e-8));
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&twist, 1), positions);
  deformer.refine(positions, 0);
  const double paper_energy = deformer.refinement_status().unrefined_energy;
  deformer.refine(positions, 2000);
  EXPECT_LT(deformer.refinement_status().energy, paper_energy);

  // The mean turn of each level of the bar about z, unwrapped from bottom to top.
  std::map<double, Eigen::Vector2d> level_direction;
  for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) {
    const Eigen::Vector2d rest(shape.mesh.positions(v, 0), shape.mesh.positions(v, 1));
    const Eigen::Vector2d now(positions(v, 0), positions(v, 1));
    if (rest.norm() < 1e-9) continue;
    // The turn of this vertex about z as a unit complex number, summed per level.
    const std::complex<double> turn = std::complex<double>(now.x(), now.y()) / std::complex<double>(rest.x(), rest.y());
    ASSERT_GT(std::abs(turn), 0.1) << "vertex " << v << " fell onto the axis";
    auto [level, added] = level_direction.try_emplace(shape.mesh.positions(v, 2), Eigen::Vector2d::Zero());
    level->second += Eigen::Vector2d(turn.real(), turn.imag()) / std::abs(turn);
  }
  ASSERT_GT(level_direction.size(), 20u);
  std::vector<double> angles;
  double previous = 0.0;
  for (const auto& [z, direction] : level_direction) {
    const double raw = std::atan2(direction.y(), direction.x());
    if (angles.empty()) {
      angles.push_back(raw);
    } else {
      double step = raw - previous;
      step -= 2.0 * kPi * std::round(step / (2.0 * kPi));
      angles.push_back(angles.back() + step);
    }
    previous = raw;
  }
  for (std::size_t k = 1; k < angles.size(); ++k) EXPECT_GE(angles[k], angles[k - 1] - 1e-6) << "level " << k;
  EXPECT_NEAR(angles.front(), 0.0, 1e-9);
  EXPECT_NEAR(angles.back() - angles.front(), 4.0 * kPi, 5.0 * kPi / 180.0);
}

}  // namespace
}  // namespace hdeform

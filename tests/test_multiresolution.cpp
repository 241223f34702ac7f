// A deformer on a base mesh: it agrees with the exact solve where it must (a base that is the mesh
// itself, nothing moved, fixed and handle vertices), stays close where it approximates (a mesh
// with relief), carries small handles to the base or refuses them by name, and reports its
// set-up's progress and findings.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/multiresolution.h"
#include "hdeform/shapes.h"
#include "hdeform/subdivision.h"
#include "multiresolution_meshes.h"
#include "test_support.h"

namespace hdeform {
namespace {

using test::torus;
using test::bar_with_relief;
using test::multiresolution;
using test::Relief;

constexpr double kPi = std::numbers::pi;

TEST(Multiresolution, TheSetUpReportsTheCollapsesInTenthsOnTheConstructingThread) {
  const Mesh mesh = torus(400, 170);
  EditConstraints constraints;
  constraints.fixed.resize(170);
  std::iota(constraints.fixed.begin(), constraints.fixed.end(), 0);
  constraints.handles.assign(1, std::vector<int>(170));
  std::iota(constraints.handles[0].begin(), constraints.handles[0].end(), 200 * 170);
  const auto caller = std::this_thread::get_id();
  std::vector<std::string> stages;
  bool elsewhere = false;
  const Deformer deformer(mesh, constraints, multiresolution(mesh.vertex_count() / 10), [&](std::string_view stage) {
    elsewhere = elsewhere || std::this_thread::get_id() != caller;
    stages.emplace_back(stage);
  });
  EXPECT_FALSE(elsewhere);
  const std::string building = "building a base mesh of about " + std::to_string(mesh.vertex_count() / 10) + " vertices (multiresolution)";
  ASSERT_FALSE(stages.empty());
  EXPECT_EQ(stages.front(), building);
  std::vector<int> percents;
  std::size_t last_share = 0;
  for (std::size_t i = 1; i < stages.size(); ++i) {
    if (stages[i].rfind(building + ": ", 0) != 0) continue;
    percents.push_back(std::stoi(stages[i].substr(building.size() + 2)));
    last_share = i;
  }
  ASSERT_GE(percents.size(), 2u) << "the collapses' progress, in tenths";
  EXPECT_TRUE(std::is_sorted(percents.begin(), percents.end()));
  EXPECT_EQ(std::adjacent_find(percents.begin(), percents.end()), percents.end()) << "each tenth once";
  for (const int percent : percents) {
    EXPECT_EQ(percent % 10, 0);
    EXPECT_GT(percent, 0);
    EXPECT_LT(percent, 100);
  }
  ASSERT_LT(last_share + 1, stages.size());
  EXPECT_EQ(stages[last_share + 1].rfind("encoding the detail", 0), 0u) << stages[last_share + 1];
}

TEST(Multiresolution, ABaseThatIsTheMeshSolvesAsTheExactDeformer) {
  const Shape shape = make_shape(ShapeKind::Cactus, 24);
  DeformerOptions exact_options;
  exact_options.resolution = Resolution::Exact;
  Deformer exact(shape.mesh, shape.demo_constraints, exact_options);
  Deformer multi(shape.mesh, shape.demo_constraints, multiresolution(shape.mesh.vertex_count()));
  EXPECT_EQ(multi.resolution(), Resolution::Multiresolution);
  EXPECT_EQ(exact.resolution(), Resolution::Exact);
  Eigen::MatrixXd expected, positions;
  exact.deform(std::span(&shape.demo_transform, 1), expected);
  multi.deform(std::span(&shape.demo_transform, 1), positions);
  EXPECT_LE(test::relative_difference(positions, expected), 1e-12);
  EXPECT_LE(test::relative_difference(multi.field(), exact.field()), 1e-12);
  exact.refine(expected, 30);
  multi.refine(positions, 30);
  EXPECT_LE(test::relative_difference(positions, expected), 1e-12);
  EXPECT_NEAR(multi.refinement_status().energy, exact.refinement_status().energy, 1e-12 * exact.refinement_status().energy);
}

TEST(Multiresolution, NothingMovedGivesTheMeshBackToTheLastBit) {
  const Relief relief = bar_with_relief();
  Deformer deformer(relief.mesh, relief.constraints, multiresolution(relief.mesh.vertex_count() / 8));
  ASSERT_LT(deformer.solved_mesh().vertex_count(), relief.mesh.vertex_count());
  Eigen::MatrixXd positions;
  const HandleTransform identity = HandleTransform::identity();
  deformer.deform(std::span(&identity, 1), positions);
  EXPECT_TRUE((positions.array() == relief.mesh.positions.array()).all());
  // After another pose, too: nothing is carried over.
  deformer.deform(std::span(&relief.transform, 1), positions);
  deformer.deform(std::span(&identity, 1), positions);
  EXPECT_TRUE((positions.array() == relief.mesh.positions.array()).all());
}

TEST(Multiresolution, FixedAndHandleVerticesEndWhereTheirConstraintsPutThem) {
  const Relief relief = bar_with_relief();
  DeformerOptions options = multiresolution(relief.mesh.vertex_count() / 8);
  options.prepare_refinement = true;
  Deformer deformer(relief.mesh, relief.constraints, options);
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&relief.transform, 1), positions);
  auto check = [&](const char* when) {
    SCOPED_TRACE(when);
    for (const int v : relief.constraints.fixed) ASSERT_TRUE((positions.row(v).array() == relief.mesh.positions.row(v).array()).all()) << v;
    for (const int v : relief.constraints.handles[0]) {
      const Eigen::RowVector3d target = relief.transform.apply(relief.mesh.positions.row(v).transpose()).transpose();
      ASSERT_TRUE((positions.row(v).array() == target.array()).all()) << v;
    }
  };
  check("the paper's update");
  EXPECT_GT(deformer.refine(positions, 20), 0);
  check("refined");
}

// On a base, refined iterations left unwritten leave the fine mesh alone; written, the fine mesh
// is rebuilt from the base they reached: what refine() gives, to the last bit.
TEST(Multiresolution, RefinedIterationsLeftUnwrittenAreRebuiltWithTheBitsOfRefine) {
  const Relief relief = bar_with_relief();
  DeformerOptions options = multiresolution(relief.mesh.vertex_count() / 8);
  options.prepare_refinement = true;
  Deformer unwritten(relief.mesh, relief.constraints, options), written(relief.mesh, relief.constraints, options);
  ASSERT_LT(unwritten.solved_mesh().vertex_count(), relief.mesh.vertex_count());
  Eigen::MatrixXd positions, expected;
  unwritten.deform(std::span(&relief.transform, 1), positions);
  written.deform(std::span(&relief.transform, 1), expected);
  const Eigen::MatrixXd papers = positions;
  ASSERT_EQ(unwritten.refine_unwritten(positions, 4), 4);
  EXPECT_TRUE((positions.array() == papers.array()).all());
  ASSERT_EQ(written.refine(expected, 4), 4);
  ASSERT_GT((expected - papers).cwiseAbs().maxCoeff(), 1e-6 * relief.diagonal);
  unwritten.write_refined(positions);
  EXPECT_TRUE((positions.array() == expected.array()).all());
}

// The editor's drag asks for a proxy's vertices alone: those come out with the bits the whole
// update gives them, the others are left as they were, and complete() then gives the whole
// update to the last bit; an exact solve writes every vertex anyway.
TEST(Multiresolution, SomeVerticesNowAndTheRestLaterGiveTheWholeUpdate) {
  const Relief relief = bar_with_relief();
  DeformerOptions options = multiresolution(relief.mesh.vertex_count() / 8);
  Deformer whole(relief.mesh, relief.constraints, options), partial(relief.mesh, relief.constraints, options);
  Eigen::MatrixXd expected, positions = relief.mesh.positions;
  whole.deform(std::span(&relief.transform, 1), expected);
  std::vector<int> some;
  for (int v = 0; v < relief.mesh.vertex_count(); v += 7) some.push_back(v);
  const Eigen::MatrixXd before = positions;
  EXPECT_FALSE(partial.deform_vertices(std::span(&relief.transform, 1), positions, some));
  std::vector<char> rebuilt(static_cast<std::size_t>(relief.mesh.vertex_count()), 0);
  for (const int v : some) rebuilt[static_cast<std::size_t>(v)] = 1;
  for (const int v : relief.constraints.fixed) rebuilt[static_cast<std::size_t>(v)] = 1;
  for (const int v : relief.constraints.handles[0]) rebuilt[static_cast<std::size_t>(v)] = 1;
  std::size_t wrong = 0, moved_elsewhere = 0;
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    if (rebuilt[static_cast<std::size_t>(v)]) wrong += (positions.row(v).array() != expected.row(v).array()).any() ? 1 : 0;
    else moved_elsewhere += (positions.row(v).array() != before.row(v).array()).any() ? 1 : 0;
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_EQ(moved_elsewhere, 0u) << "rows outside the request were written";
  EXPECT_GT((expected - before).cwiseAbs().maxCoeff(), 0.01 * relief.diagonal);  // the test would see a missed row
  partial.complete(positions);
  EXPECT_TRUE((positions.array() == expected.array()).all());
  // Positions of another size cannot keep the other rows.
  Eigen::MatrixXd empty;
  EXPECT_THROW(partial.deform_vertices(std::span(&relief.transform, 1), empty, some), std::invalid_argument);
  // Solved exactly, every row is written.
  Deformer exact(relief.mesh, relief.constraints);
  Eigen::MatrixXd exact_expected, exact_positions = relief.mesh.positions;
  exact.deform(std::span(&relief.transform, 1), exact_expected);
  EXPECT_TRUE(exact.deform_vertices(std::span(&relief.transform, 1), exact_positions, some));
  EXPECT_TRUE((exact_positions.array() == exact_expected.array()).all());
}

// The first of the relief bar's handle vertices (near its top) that the base does not have; −1 if none.
int handle_vertex_off_the_base(const Relief& relief, const DetailEncoding& encoding) {
  for (const int v : relief.constraints.handles[0]) {
    if (encoding.base_vertex(v) < 0) return v;
  }
  return -1;
}

TEST(Multiresolution, AHandleSmallerThanABaseTriangleReachesTheBase) {
  const Relief relief = bar_with_relief();
  const auto operators = MeshOperators::of(relief.mesh, Resolution::Multiresolution, relief.mesh.vertex_count() / 20);
  const DetailEncoding& encoding = operators->multiresolution->encoding;
  const int lone = handle_vertex_off_the_base(relief, encoding);
  ASSERT_GE(lone, 0);
  EditConstraints constraints{relief.constraints.fixed, {{lone}}, {}};
  const EditConstraints base = base_constraints(constraints, relief.mesh.triangles, encoding).constraints;
  // It pins the corner of its foot triangle nearest its foot.
  const auto corners = encoding.foot_corners(lone);
  const auto weights = encoding.foot_weights(lone);
  const auto nearest = static_cast<std::size_t>(std::max_element(weights.begin(), weights.end()) - weights.begin());
  ASSERT_EQ(base.handles.size(), 1u);
  EXPECT_EQ(base.handles[0], std::vector<int>{corners[nearest]});
  // With the nearest corner's fine vertex painted fixed, the handle takes another corner of its foot.
  int nearest_fine = -1;
  for (int v = 0; v < relief.mesh.vertex_count() && nearest_fine < 0; ++v) {
    if (encoding.base_vertex(v) == corners[nearest]) nearest_fine = v;
  }
  ASSERT_GE(nearest_fine, 0);
  EditConstraints nearest_fixed{relief.constraints.fixed, {{lone}}, {}};
  nearest_fixed.fixed.push_back(nearest_fine);
  const EditConstraints elsewhere = base_constraints(nearest_fixed, relief.mesh.triangles, encoding).constraints;
  ASSERT_EQ(elsewhere.handles[0].size(), 1u);
  EXPECT_NE(elsewhere.handles[0][0], corners[nearest]);
  EXPECT_NE(std::find(corners.begin(), corners.end(), elsewhere.handles[0][0]), corners.end());
  Deformer deformer(relief.mesh, constraints, operators, multiresolution(relief.mesh.vertex_count() / 20));
  EXPECT_EQ(deformer.operators().get(), operators.get()) << "the operators given are used, not built again";
  const HandleTransform pull = HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero(), 0.0, 1.0,
                                                            Eigen::Vector3d(0, 0, 0.05 * relief.diagonal));
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&pull, 1), positions);
  EXPECT_TRUE((positions.row(lone).array() == pull.apply(relief.mesh.positions.row(lone).transpose()).transpose().array()).all());
}

// The largest ratio of deformed to rest length over the edges at `vertex`.
double largest_stretch_at(const Mesh& rest, const Eigen::MatrixXd& deformed, int vertex) {
  double largest = 0.0;
  for (Eigen::Index t = 0; t < rest.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      if (rest.triangles(t, k) != vertex) continue;
      for (const int other : {rest.triangles(t, (k + 1) % 3), rest.triangles(t, (k + 2) % 3)}) {
        largest = std::max(largest, (deformed.row(vertex) - deformed.row(other)).norm() /
                                        (rest.positions.row(vertex) - rest.positions.row(other)).norm());
      }
    }
  }
  return largest;
}

// The vertex halfway up the relief bar (along its longest extent) that the base does not have.
int middle_vertex_off_the_base(const Relief& relief, const DetailEncoding& encoding) {
  Eigen::Index axis = 0;
  (relief.mesh.positions.colwise().maxCoeff() - relief.mesh.positions.colwise().minCoeff()).maxCoeff(&axis);
  const double middle = 0.5 * (relief.mesh.positions.col(axis).maxCoeff() + relief.mesh.positions.col(axis).minCoeff());
  int found = -1;
  double closest = std::numeric_limits<double>::infinity();
  for (int v = 0; v < relief.mesh.vertex_count(); ++v) {
    const double off = std::abs(relief.mesh.positions(v, axis) - middle);
    if (encoding.base_vertex(v) < 0 && off < closest) {
      closest = off;
      found = v;
    }
  }
  return found;
}

// The relief bar on a base of a twentieth of its vertices, and its vertex halfway up that the base
// does not have.
class MiddleVertexOffTheBase : public ::testing::Test {
 protected:
  const Relief relief = bar_with_relief();
  const Eigen::Index base_size = relief.mesh.vertex_count() / 20;
  const std::shared_ptr<const MeshOperators> operators = MeshOperators::of(relief.mesh, Resolution::Multiresolution, base_size);
  const DetailEncoding& encoding = operators->multiresolution->encoding;
  const int lone = middle_vertex_off_the_base(relief, encoding);
};

TEST_F(MiddleVertexOffTheBase, EachPatchOfAFixedSetReachesTheBase) {
  // The fixed set: the bar's foot, which the base has vertices of, and one vertex halfway up that
  // the base does not have (a second patch, as a scan's other paws are).
  ASSERT_GE(lone, 0);
  EditConstraints constraints = relief.constraints;
  ASSERT_EQ(std::count(constraints.fixed.begin(), constraints.fixed.end(), lone), 0);
  constraints.fixed.push_back(lone);
  const EditConstraints base = base_constraints(constraints, relief.mesh.triangles, encoding).constraints;
  const auto corners = encoding.foot_corners(lone);
  const auto weights = encoding.foot_weights(lone);
  EXPECT_NEAR(weights[0] + weights[1] + weights[2], 1.0, 1e-12);
  const auto nearest = static_cast<std::size_t>(std::max_element(weights.begin(), weights.end()) - weights.begin());
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(std::count(base.fixed.begin(), base.fixed.end(), corners[k]), k == nearest ? 1 : 0)
        << "base vertex " << corners[k] << " under the lone fixed vertex, weight " << weights[k];
  }

  // The bar bent: around the lone vertex the result stays as whole as the exact solve's, where the
  // base left free there would pull the vertex's neighbours away from it.
  Eigen::MatrixXd on_base, exact;
  Deformer(relief.mesh, constraints, operators, multiresolution(base_size)).deform(std::span(&relief.transform, 1), on_base);
  Deformer(relief.mesh, constraints).deform(std::span(&relief.transform, 1), exact);
  const double exact_stretch = largest_stretch_at(relief.mesh, exact, lone);
  EXPECT_LT(largest_stretch_at(relief.mesh, on_base, lone), 1.5 * exact_stretch) << "exact: " << exact_stretch;
}

TEST_F(MiddleVertexOffTheBase, AFixedPatchThatNoBaseVertexCanHoldIsNamedInTheWarnings) {
  // One fixed vertex halfway up, every vertex around it in the handle: each base vertex under it
  // belongs to the handle, so the base cannot hold it, and the user is told.
  ASSERT_GE(lone, 0);
  EditConstraints constraints{relief.constraints.fixed, {{}}, {}};
  constraints.fixed.push_back(lone);
  std::vector<char> fixed(static_cast<std::size_t>(relief.mesh.vertex_count()), 0);
  for (const int v : constraints.fixed) fixed[static_cast<std::size_t>(v)] = 1;
  for (int v = 0; v < relief.mesh.vertex_count(); ++v) {
    if (!fixed[static_cast<std::size_t>(v)]) constraints.handles[0].push_back(v);
  }
  const BaseConstraints carried = base_constraints(constraints, relief.mesh.triangles, encoding);
  EXPECT_EQ(carried.unheld_vertices, (std::vector<std::size_t>{1, 0}));
  for (const int corner : encoding.foot_corners(lone)) {
    EXPECT_EQ(std::count(carried.constraints.fixed.begin(), carried.constraints.fixed.end(), corner), 0);
  }
  const Deformer deformer(relief.mesh, constraints, operators, multiresolution(base_size));
  const auto warnings = deformer.warnings();
  const std::string expected = "1 fixed vertex reaches no vertex of the base mesh (";
  EXPECT_EQ(std::count_if(warnings.begin(), warnings.end(), [&](const std::string& line) { return line.find(expected) == 0; }), 1)
      << ::testing::PrintToString(warnings);
  // With the bar's own sets every patch holds a base vertex: no such warning.
  const Deformer usual(relief.mesh, relief.constraints, operators, multiresolution(base_size));
  for (const auto& line : usual.warnings()) EXPECT_EQ(line.find("no vertex of the base mesh"), std::string::npos) << line;
}

TEST(Multiresolution, AHandleThatReachesNoBaseVertexOfItsOwnIsRefusedByName) {
  // Every other vertex fixed: each base vertex under the lone handle vertex is already fixed.
  const Relief relief = bar_with_relief();
  const auto operators = MeshOperators::of(relief.mesh, Resolution::Multiresolution, relief.mesh.vertex_count() / 20);
  int lone = -1;
  for (int v = 0; v < relief.mesh.vertex_count() && lone < 0; ++v) {
    if (operators->multiresolution->encoding.base_vertex(v) < 0) lone = v;
  }
  ASSERT_GE(lone, 0);
  EditConstraints constraints;
  for (int v = 0; v < relief.mesh.vertex_count(); ++v) {
    if (v != lone) constraints.fixed.push_back(v);
  }
  constraints.handles = {{lone}};
  try {
    const Deformer deformer(relief.mesh, constraints, operators, multiresolution(relief.mesh.vertex_count() / 20));
    ADD_FAILURE() << "a handle without a base vertex was accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("handle 1 (1 vertex) reaches no vertex of the base mesh"), std::string::npos) << error.what();
  }
}

TEST(Multiresolution, OperatorsOfTheOtherResolutionAreBuiltAgain) {
  const Shape shape = make_shape(ShapeKind::Cactus, 16);
  const auto exact = MeshOperators::of(shape.mesh, Resolution::Exact);
  Deformer deformer(shape.mesh, shape.demo_constraints, exact, multiresolution(shape.mesh.vertex_count() / 4));
  EXPECT_EQ(deformer.resolution(), Resolution::Multiresolution);
  EXPECT_NE(deformer.operators().get(), exact.get());
  // Automatic takes either: below the threshold it would be exact, the operators given say otherwise.
  Deformer automatic(shape.mesh, shape.demo_constraints, deformer.operators());
  EXPECT_EQ(automatic.resolution(), Resolution::Multiresolution);
  EXPECT_EQ(resolution_for(kMultiresolutionFrom - 1), Resolution::Exact);
  EXPECT_EQ(resolution_for(kMultiresolutionFrom), Resolution::Multiresolution);
  EXPECT_EQ(resolution_for(kMultiresolutionFrom, Resolution::Exact), Resolution::Exact);
}

// Against the exact solve on a mesh with relief (6,914 vertices, a base of 864): the base carries
// the smooth deformation, the detail rides on it. Measured: mean deviation 6.4e-4 of the
// diagonal, of which 2.6e-4 is the base's coarser solve alone (the same bar and base without
// relief), and normals 0.96° apart on average; the thresholds are twice that. A foot on the
// wrong side or a frame turned wrongly moves vertices by the relief's size (4e-3 of the
// diagonal) and turns normals by tens of degrees.
TEST(Multiresolution, AReliefFollowsTheExactSolveClosely) {
  const Relief relief = bar_with_relief();
  DeformerOptions exact_options;
  exact_options.resolution = Resolution::Exact;
  Deformer exact(relief.mesh, relief.constraints, exact_options);
  Deformer multi(relief.mesh, relief.constraints, multiresolution(relief.mesh.vertex_count() / 8));
  Eigen::MatrixXd expected, positions;
  exact.deform(std::span(&relief.transform, 1), expected);
  multi.deform(std::span(&relief.transform, 1), positions);
  const Eigen::VectorXd deviation = (positions - expected).rowwise().norm();
  const double mean_deviation = deviation.mean() / relief.diagonal;
  const Eigen::MatrixXd n_exact = vertex_normals(expected, relief.mesh.triangles), n_multi = vertex_normals(positions, relief.mesh.triangles);
  const Eigen::VectorXd cosines = (n_exact.array() * n_multi.array()).rowwise().sum().min(1.0);
  const double mean_angle = cosines.array().acos().mean() * 180.0 / kPi;
  RecordProperty("mean_deviation", std::to_string(mean_deviation));
  RecordProperty("mean_normal_angle_degrees", std::to_string(mean_angle));
  std::cout << "relief: mean deviation " << mean_deviation << " of the diagonal, normals " << mean_angle << " degrees apart on average\n";
  EXPECT_LT(mean_deviation, 1.3e-3);
  EXPECT_LT(mean_angle, 2.0);
  // The twist moved the top by far more than that.
  EXPECT_GT((expected - relief.mesh.positions).rowwise().norm().maxCoeff() / relief.diagonal, 0.1);
}

TEST(Multiresolution, SaysWhenTheBaseKeepsMoreVerticesThanAskedFor) {
  // A tube's two boundary loops (80 vertices) stay, so a base of 20 cannot be had: the user is
  // told what the base has instead. A size the collapses reach says nothing.
  const Mesh tube = torus(40, 40, true);
  EditConstraints constraints;
  constraints.fixed.resize(40);
  std::iota(constraints.fixed.begin(), constraints.fixed.end(), 0);
  constraints.handles.assign(1, std::vector<int>(40));
  std::iota(constraints.handles[0].begin(), constraints.handles[0].end(), static_cast<int>(tube.vertex_count()) - 40);
  auto base_warnings = [&](Eigen::Index asked) {
    const Deformer deformer(tube, constraints, multiresolution(asked));
    std::vector<std::string> lines;
    for (const auto& line : deformer.warnings()) {
      if (line.find("were asked for") != std::string::npos) lines.push_back(line);
    }
    return std::pair(deformer.solved_mesh().vertex_count(), lines);
  };
  const auto [small_base, small_warnings] = base_warnings(20);
  EXPECT_GE(small_base, 80);
  ASSERT_EQ(small_warnings.size(), 1u);
  EXPECT_NE(small_warnings[0].find("has " + std::to_string(small_base) + " vertices where 20 were asked for"), std::string::npos) << small_warnings[0];
  const auto [reached_base, reached_warnings] = base_warnings(tube.vertex_count() / 4);
  EXPECT_LE(reached_base, tube.vertex_count() / 4 + tube.vertex_count() / 40);
  EXPECT_TRUE(reached_warnings.empty()) << reached_warnings[0];
}

}  // namespace
}  // namespace hdeform

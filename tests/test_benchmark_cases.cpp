// The Botsch–Sorkine deformation benchmark from ../shared/meshes/deformation-benchmark.
#include "hdeform/constraint_io.h"
#include "hdeform/deformer.h"
#include "hdeform/mesh_io.h"
#include "test_support.h"

namespace hdeform {
namespace {

class BenchmarkCase : public ::testing::TestWithParam<std::string> {};

TEST_P(BenchmarkCase, KeepsConstraintsExactAndStaysFinite) {
  HDEFORM_REQUIRE_SHARED_MESHES();
  const auto folder = test::shared_meshes() / "deformation-benchmark";
  const std::string name = GetParam();
  const Mesh mesh = read_obj(folder / (name + ".obj"));
  EditConstraints constraints;
  constraints.fixed = read_vertex_indices(folder / (name + "-fixed.txt"), mesh.vertex_count());
  constraints.handles = {read_vertex_indices(folder / (name + "-handle.txt"), mesh.vertex_count())};
  const auto transform = read_handle_transform(folder / (name + "-transform.txt"));

  Deformer deformer(mesh, constraints);
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&transform, 1), positions);
  // The paper's result, then refined: both keep the constraints exact.
  for (const bool refined : {false, true}) {
    if (refined) {
      deformer.refine(positions, 40);
      EXPECT_LT(deformer.refinement_status().energy, deformer.refinement_status().unrefined_energy) << name;
    }
    const std::string what = name + (refined ? " refined" : "");
    ASSERT_TRUE(positions.allFinite()) << what;
    for (const int v : constraints.fixed) EXPECT_EQ(positions.row(v), mesh.positions.row(v)) << what << " vertex " << v;
    for (const int v : constraints.handles[0]) {
      EXPECT_EQ(positions.row(v).transpose(), transform.apply(mesh.positions.row(v).transpose())) << what << " vertex " << v;
    }
    // Something moved, and nothing flew away.
    const double diagonal = bounding_box_diagonal(mesh.positions);
    const double largest_move = (positions - mesh.positions).rowwise().norm().maxCoeff();
    EXPECT_GT(largest_move, 1e-3 * diagonal) << what;
    EXPECT_LT(largest_move, 3.0 * diagonal) << what;
  }
}

INSTANTIATE_TEST_SUITE_P(DeformationBenchmark, BenchmarkCase, ::testing::Values("bar", "cactus", "cylinder", "plane"));

}  // namespace
}  // namespace hdeform

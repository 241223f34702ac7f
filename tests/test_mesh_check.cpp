#include <limits>

#include "hdeform/deformation_gradient.h"
#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/laplacian.h"
#include "hdeform/transfer.h"
#include "hdeform/mesh_check.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "test_support.h"

namespace hdeform {
namespace {

bool any_contains(const std::vector<std::string>& lines, const std::string& fragment) {
  return std::any_of(lines.begin(), lines.end(), [&](const std::string& line) { return line.find(fragment) != std::string::npos; });
}

// A cylinder, plus: a second, unconstrained copy far away; a duplicated triangle; an extra
// triangle on an existing edge (non-manifold); an unreferenced vertex; a zero-area triangle.
Mesh troubled_mesh(const Mesh& base) {
  const auto n = base.vertex_count();
  const auto m = base.triangle_count();
  Mesh mesh;
  mesh.positions.resize(2 * n + 2, 3);
  mesh.positions << base.positions, base.positions.rowwise() + Eigen::RowVector3d(5, 0, 0), Eigen::RowVector3d(9, 9, 9),
      Eigen::RowVector3d(0, 0, 3);
  mesh.triangles.resize(2 * m + 3, 3);
  mesh.triangles << base.triangles, base.triangles.array() + static_cast<int>(n), base.triangles.row(0),
      Eigen::RowVector3i(base.triangles(0, 0), base.triangles(0, 1), static_cast<int>(2 * n + 1)),
      Eigen::RowVector3i(base.triangles(1, 0), base.triangles(1, 0) == base.triangles(1, 1) ? 0 : base.triangles(1, 1), base.triangles(1, 0));
  // The last row repeats a vertex: a collapsed triangle.
  return mesh;
}

TEST(MeshCheck, CountsAndWarnsAboutTroubledGeometry) {
  const auto shape = make_shape(ShapeKind::Cylinder, 16);
  const Mesh mesh = troubled_mesh(shape.mesh);
  const auto weights = cotangent_weights(mesh);
  const auto inspection = inspect_mesh(mesh, weights);
  EXPECT_EQ(inspection.components, 2u);
  EXPECT_EQ(inspection.unreferenced_vertices, 1u);
  EXPECT_EQ(inspection.ignored_triangles, 2u);  // the duplicate and the collapsed one
  EXPECT_GE(inspection.nonmanifold_edges, 3u);
  const auto warnings = inspection.warnings();
  EXPECT_TRUE(any_contains(warnings, "2 connected components"));
  EXPECT_TRUE(any_contains(warnings, "non-manifold"));
  EXPECT_TRUE(any_contains(warnings, "unreferenced"));
  EXPECT_TRUE(any_contains(warnings, "duplicated"));
}

TEST(MeshCheck, TroubledGeometryStillDeformsAndTheUnconstrainedPartsStayPut) {
  const auto shape = make_shape(ShapeKind::Cylinder, 16);
  const Mesh mesh = troubled_mesh(shape.mesh);
  Deformer deformer(mesh, shape.demo_constraints);
  const auto warnings = deformer.warnings();
  EXPECT_TRUE(any_contains(warnings, "stay in place"));
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&shape.demo_transform, 1), positions);
  ASSERT_TRUE(positions.allFinite());
  const auto n = shape.mesh.vertex_count();
  // The unconstrained copy and the unreferenced vertex stay exactly where they were.
  for (Eigen::Index v = n; v <= 2 * n; ++v) EXPECT_EQ(positions.row(v), mesh.positions.row(v)) << "vertex " << v;
  EXPECT_GT((positions.topRows(n) - mesh.positions.topRows(n)).cwiseAbs().maxCoeff(), 0.05);
}

// Meshes that no reader would build but a caller of the library can: each must be refused by
// every public entry point, naming the element, before anything reads past an array.
std::vector<std::pair<std::string, Mesh>> broken_meshes(const Mesh& good) {
  Mesh out_of_range = good, negative = good, not_a_number = good;
  out_of_range.triangles(7, 2) = static_cast<int>(good.vertex_count()) + 3;
  negative.triangles(2, 0) = -4;
  not_a_number.positions(5, 2) = std::numeric_limits<double>::quiet_NaN();
  return {{"triangle 7 corner 2 has vertex index " + std::to_string(good.vertex_count() + 3), out_of_range},
          {"triangle 2 corner 0 has vertex index -4", negative},
          {"vertex 5 has a non-finite coordinate z = nan", not_a_number}};
}

template <class Call>
void expect_refusal(const std::string& entry, const std::string& fragment, Call&& call) {
  try {
    call();
    ADD_FAILURE() << entry << " accepted a mesh with " << fragment;
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos) << entry << ": " << error.what();
  }
}

TEST(MeshCheck, EveryEntryPointRefusesABrokenMeshNamingTheElement) {
  const auto shape = make_shape(ShapeKind::Cylinder, 16);
  const MarkerPairs markers{{0, 40, 80, 120}, {0, 40, 80, 120}};
  for (const auto& [fragment, mesh] : broken_meshes(shape.mesh)) {
    expect_refusal("Deformer", fragment, [&] { Deformer(mesh, shape.demo_constraints); });
    expect_refusal("cotangent_weights (Laplacian, harmonic field)", fragment, [&] { cotangent_weights(mesh); });
    expect_refusal("cotangent_laplacian", fragment, [&] { cotangent_laplacian(mesh); });
    expect_refusal("DeformationTransfer (source)", "source mesh: " + fragment,
                   [&] { DeformationTransfer(mesh, shape.mesh, markers); });
    expect_refusal("DeformationTransfer (target)", "target mesh: " + fragment,
                   [&] { DeformationTransfer(shape.mesh, mesh, markers); });
    for (const auto method : {TransferMethod::Correspondence, TransferMethod::Interpolation}) {
      TransferOptions options;
      options.method = method;
      expect_refusal("DeformationTransfer (" + std::string(to_string(method)) + ")", fragment,
                     [&] { DeformationTransfer(shape.mesh, mesh, markers, options); });
    }
  }
  std::vector<Eigen::Matrix3d> gradients;
  expect_refusal("deformation_gradients", "posed positions", [&] {
    deformation_gradients(shape.mesh, shape.mesh.positions.topRows(4), gradients);
  });
}

TEST(MeshCheck, StanfordBunnyWithUnreferencedVerticesAndHoles) {
  HDEFORM_REQUIRE_SHARED_MESHES();
  const Mesh bunny = read_obj(test::shared_meshes() / "bunny" / "stanford-bunny.obj");
  const auto inspection = inspect_mesh(bunny, cotangent_weights(bunny));
  EXPECT_EQ(inspection.unreferenced_vertices, 1113u);
  EXPECT_GT(inspection.boundary_edges, 0u);
  // Ears up: fix the lowest part, pull the highest.
  EditConstraints constraints;
  const double low = bunny.positions.col(1).minCoeff(), high = bunny.positions.col(1).maxCoeff();
  std::vector<int> top;
  for (Eigen::Index v = 0; v < bunny.vertex_count(); ++v) {
    if (bunny.positions(v, 1) < low + 0.1 * (high - low)) constraints.fixed.push_back(static_cast<int>(v));
    if (bunny.positions(v, 1) > high - 0.05 * (high - low)) top.push_back(static_cast<int>(v));
  }
  constraints.handles = {top};
  Deformer deformer(bunny, constraints);
  EXPECT_TRUE(any_contains(deformer.warnings(), "1113 unreferenced vertices"));
  Eigen::Matrix<double, 3, 4> affine;
  affine << Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.02, 0.01, 0.0);
  const auto transform = HandleTransform::from_affine(affine);
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&transform, 1), positions);
  ASSERT_TRUE(positions.allFinite());
  for (Eigen::Index v = 0; v < bunny.vertex_count(); ++v) {
    if (deformer.partition().role[static_cast<std::size_t>(v)] == VertexRole::Fixed) {
      EXPECT_EQ(positions.row(v), bunny.positions.row(v));
    }
  }
}

}  // namespace
}  // namespace hdeform

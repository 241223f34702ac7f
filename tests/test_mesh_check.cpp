#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <utility>

#include "hdeform/deformation_gradient.h"
#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/constraint_io.h"
#include "hdeform/handle_shape.h"
#include "hdeform/laplacian.h"
#include "hdeform/transfer.h"
#include "hdeform/mesh_check.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "test_support.h"
#include "mesh/edge_counts.h"

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

// The edge counts of inspections and topologies against a map from each edge to its triangles
// and a components search written here, on random triangle lists: shared, boundary and
// non-manifold edges, corners repeated, vertices in no triangle.
TEST(EdgeCounts, AgreeWithCountingEachEdgeInAMap) {
  std::mt19937 random(7);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 2 + static_cast<int>(random() % 60);
    const int m = 1 + static_cast<int>(random() % 120);
    Eigen::MatrixXi triangles(m, 3);
    for (int t = 0; t < m; ++t) {
      for (int k = 0; k < 3; ++k) triangles(t, k) = static_cast<int>(random() % static_cast<unsigned>(n));
    }
    for (const bool self_edges : {false, true}) {
      SCOPED_TRACE(testing::Message() << "trial " << trial << (self_edges ? ", self edges" : ""));
      std::map<std::pair<int, int>, int> holders;
      std::vector<std::vector<int>> neighbours(static_cast<std::size_t>(n));
      for (int t = 0; t < m; ++t) {
        for (int k = 0; k < 3; ++k) {
          const int a = triangles(t, k), b = triangles(t, (k + 1) % 3);
          if (a == b && !self_edges) continue;
          ++holders[{std::min(a, b), std::max(a, b)}];
          neighbours[static_cast<std::size_t>(a)].push_back(b);
          neighbours[static_cast<std::size_t>(b)].push_back(a);
        }
      }
      std::size_t boundary = 0, nonmanifold = 0;
      for (const auto& [edge, count] : holders) {
        boundary += count == 1 ? 1 : 0;
        nonmanifold += count > 2 ? 1 : 0;
      }
      detail::DisjointSets sets(static_cast<std::size_t>(n));
      const detail::EdgeCounts counts = detail::count_edges(triangles, static_cast<std::size_t>(n), self_edges, &sets);
      EXPECT_EQ(counts.edges, holders.size());
      EXPECT_EQ(counts.boundary, boundary);
      EXPECT_EQ(counts.nonmanifold, nonmanifold);
      // Components by a search along the edges: the smallest vertex of each is its root.
      std::vector<int> label(static_cast<std::size_t>(n), -1);
      for (int start = 0; start < n; ++start) {
        if (label[static_cast<std::size_t>(start)] >= 0) continue;
        std::vector<int> stack{start};
        label[static_cast<std::size_t>(start)] = start;
        while (!stack.empty()) {
          const int v = stack.back();
          stack.pop_back();
          for (const int w : neighbours[static_cast<std::size_t>(v)]) {
            if (label[static_cast<std::size_t>(w)] < 0) {
              label[static_cast<std::size_t>(w)] = start;
              stack.push_back(w);
            }
          }
        }
      }
      for (int v = 0; v < n; ++v) EXPECT_EQ(sets.find(v), label[static_cast<std::size_t>(v)]) << "vertex " << v;
    }
  }
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
  EXPECT_TRUE(any_contains(warnings, "1 unreferenced vertex (in no triangle)"));  // one, so singular
  EXPECT_TRUE(any_contains(warnings, "2 duplicated triangles or triangles with a repeated vertex"));
}

TEST(MeshCheck, TroubledGeometryStillDeformsAndTheUnconstrainedPartsStayPut) {
  const auto shape = make_shape(ShapeKind::Cylinder, 16);
  const Mesh mesh = troubled_mesh(shape.mesh);
  Deformer deformer(mesh, shape.demo_constraints);
  const auto warnings = deformer.warnings();
  // The far copy is one part, and the unreferenced vertex one vertex: each said in the singular.
  EXPECT_TRUE(any_contains(warnings, "1 part of the mesh (" + std::to_string(shape.mesh.vertex_count()) +
                                         " vertices) has no fixed or handle vertex and stays in place"));
  EXPECT_TRUE(any_contains(warnings, "1 unreferenced vertex (in no triangle) stays in place"));
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&shape.demo_transform, 1), positions);
  ASSERT_TRUE(positions.allFinite());
  const auto n = shape.mesh.vertex_count();
  // The unconstrained copy and the unreferenced vertex stay exactly where they were.
  for (Eigen::Index v = n; v <= 2 * n; ++v) EXPECT_EQ(positions.row(v), mesh.positions.row(v)) << "vertex " << v;
  EXPECT_GT((positions.topRows(n) - mesh.positions.topRows(n)).cwiseAbs().maxCoeff(), 0.05);
}

// A band round the middle of a shape (|z - middle| < 4% of its height): the whole of it, or
// only the part on the +y side of the centre, as a brush that paints what faces the camera leaves it.
std::vector<int> middle_band(const Mesh& mesh, bool half) {
  const double low = mesh.positions.col(2).minCoeff(), high = mesh.positions.col(2).maxCoeff();
  const double middle = 0.5 * (low + high), width = 0.04 * (high - low);
  const double centre_y = mesh.positions.col(1).mean();
  std::vector<int> band;
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    if (std::abs(mesh.positions(v, 2) - middle) < width && (!half || mesh.positions(v, 1) > centre_y)) {
      band.push_back(static_cast<int>(v));
    }
  }
  return band;
}

TEST(HandleShape, HalfRingsAreFoundAndRingsCapsAndPatchesAreNot) {
  for (const auto kind : {ShapeKind::Cylinder, ShapeKind::Bar, ShapeKind::Sphere, ShapeKind::Cactus}) {
    const auto shape = make_shape(kind, 32);
    SCOPED_TRACE(std::string(to_string(kind)));
    const auto half = partial_ring_degrees(shape.mesh, middle_band(shape.mesh, true));
    ASSERT_TRUE(half.has_value());
    EXPECT_GT(*half, 150.0);
    EXPECT_LT(*half, 230.0);
    EXPECT_FALSE(partial_ring_degrees(shape.mesh, middle_band(shape.mesh, false)).has_value());
    EXPECT_FALSE(partial_ring_degrees(shape.mesh, shape.demo_constraints.handles.front()).has_value());
  }
  const Mesh plane = test::planar_grid(20);
  std::vector<int> patch;
  for (int v = 0; v < 60; ++v) patch.push_back(v);
  EXPECT_FALSE(partial_ring_degrees(plane, patch).has_value());
}

// The reason for the warning: under a half ring the field is lopsided round the section, under a
// full ring it is not.
TEST(HandleShape, AHalfRingsFieldFallsOffRoundTheOtherSide) {
  const auto shape = make_shape(ShapeKind::Cylinder, 32);
  auto field_round_the_band = [&](bool half) {
    EditConstraints constraints;
    constraints.handles = {middle_band(shape.mesh, half)};
    const double low = shape.mesh.positions.col(2).minCoeff();
    for (Eigen::Index v = 0; v < shape.mesh.vertex_count(); ++v) {
      if (shape.mesh.positions(v, 2) < low + 1e-9) constraints.fixed.push_back(static_cast<int>(v));
    }
    Deformer deformer(shape.mesh, constraints);
    double lowest = 1.0;
    for (int v : middle_band(shape.mesh, false)) lowest = std::min(lowest, deformer.field()(v));
    return std::pair(lowest, deformer.warnings());
  };
  const auto [ring_lowest, ring_warnings] = field_round_the_band(false);
  const auto [half_lowest, half_warnings] = field_round_the_band(true);
  EXPECT_EQ(ring_lowest, 1.0);
  EXPECT_LT(half_lowest, 0.9);
  EXPECT_FALSE(any_contains(ring_warnings, "wraps only"));
  EXPECT_TRUE(any_contains(half_warnings, "the handle wraps only about"));
}

TEST(HandleShape, TheBenchmarkAndBuddhaHandlesAreNotFlagged) {
  HDEFORM_REQUIRE_SHARED_MESHES();
  const auto meshes = test::shared_meshes();
  for (const auto& [folder, name] : std::vector<std::pair<std::string, std::string>>{
           {"deformation-benchmark", "bar"}, {"deformation-benchmark", "cactus"}, {"deformation-benchmark", "cylinder"},
           {"deformation-benchmark", "plane"}, {"buddha", "buddha-206k"}, {"buddha", "buddha-51k"}}) {
    SCOPED_TRACE(name);
    const auto mesh = read_obj(meshes / folder / (name + ".obj"));
    const auto handle = read_vertex_indices(meshes / folder / (name + "-handle.txt"), mesh.vertex_count());
    EXPECT_FALSE(partial_ring_degrees(mesh, handle).has_value());
  }
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

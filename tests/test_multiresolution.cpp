// Multiresolution editing: the base mesh keeps the topology, the detail encoding reproduces the
// mesh exactly at rest and moves it rigidly with a rigid base, and a deformer on a base agrees
// with the exact solve where it must (a base that is the mesh itself, fixed and handle vertices)
// and stays close where it approximates (a mesh with relief).
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>
#include <set>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/multiresolution.h"
#include "hdeform/shapes.h"
#include "hdeform/subdivision.h"
#include "test_support.h"

namespace hdeform {
namespace {

constexpr double kPi = std::numbers::pi;

// A torus (genus 1, closed) or, with `open`, a tube (its two ends are boundary loops): `around`
// segments along the big circle, `across` around the tube, with a ripple so that no collapse is
// free.
Mesh torus(int around, int across, bool open = false) {
  Mesh mesh;
  const int rings = open ? around + 1 : around;
  mesh.positions.resize(rings * across, 3);
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < across; ++j) {
      const double u = 2 * kPi * i / around * (open ? 0.75 : 1.0), v = 2 * kPi * j / across;
      const double r = 0.35 * (1 + 0.05 * std::sin(5 * u) * std::cos(3 * v));
      mesh.positions.row(i * across + j) << (1 + r * std::cos(v)) * std::cos(u), (1 + r * std::cos(v)) * std::sin(u), r * std::sin(v);
    }
  }
  const int cells = open ? around : around;
  mesh.triangles.resize(2 * cells * across, 3);
  int t = 0;
  for (int i = 0; i < cells; ++i) {
    for (int j = 0; j < across; ++j) {
      const int a = i * across + j, b = ((i + 1) % rings) * across + j, c = ((i + 1) % rings) * across + (j + 1) % across,
                d = i * across + (j + 1) % across;
      mesh.triangles.row(t++) << a, b, c;
      mesh.triangles.row(t++) << a, c, d;
    }
  }
  return mesh;
}

// The bar subdivided twice, with relief: displaced along its normals by a pattern of three
// frequencies (the finest about two edges long), and its demo edit (a twist of the top end).
struct Relief {
  Mesh mesh;
  EditConstraints constraints;
  HandleTransform transform;
  double diagonal = 0.0;
};
Relief bar_with_relief() {
  const Shape bar = make_shape(ShapeKind::Bar, 16);
  Relief relief;
  Subdivision once = subdivide(bar.mesh);
  Subdivision twice = subdivide(once.mesh);
  relief.constraints = subdivided_constraints(subdivided_constraints(bar.demo_constraints, once), twice);
  relief.mesh = twice.mesh;
  relief.transform = bar.demo_transform;
  relief.diagonal = bounding_box_diagonal(relief.mesh.positions);
  add_relief(relief.mesh, 0.004);
  return relief;
}

// A sphere with a ripple whose edges are half as long on its northern half as on its southern (four
// times the vertices per area): rings of latitude as far apart as the local edge is long, each with
// as many vertices as that length allows, neighbouring rings zipped together by angle.
Mesh sphere_denser_in_the_north(double southern_edge) {
  auto edge_at = [&](double theta) { return theta < kPi / 2 ? southern_edge / 2 : southern_edge; };
  std::vector<double> latitudes{0.0};
  while (latitudes.back() < kPi) latitudes.push_back(latitudes.back() + edge_at(latitudes.back()) * std::sqrt(3.0) / 2);
  latitudes.back() = kPi;
  std::vector<Eigen::RowVector3d> points;
  std::vector<std::vector<int>> rings;
  for (std::size_t r = 0; r < latitudes.size(); ++r) {
    const double theta = latitudes[r], shift = 0.5 * static_cast<double>(r % 2);
    const bool pole = r == 0 || r + 1 == latitudes.size();
    const int count = pole ? 1 : std::max(3, static_cast<int>(std::lround(2 * kPi * std::sin(theta) / edge_at(theta))));
    std::vector<int>& ring = rings.emplace_back();
    for (int k = 0; k < count; ++k) {
      const double phi = 2 * kPi * (k + shift) / count, radius = 1 + 0.03 * std::sin(5 * theta) * std::cos(4 * phi);
      ring.push_back(static_cast<int>(points.size()));
      points.emplace_back(radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi), radius * std::cos(theta));
    }
  }
  std::vector<Eigen::RowVector3i> triangles;
  for (std::size_t r = 0; r + 1 < rings.size(); ++r) {
    const std::vector<int>&upper = rings[r], &lower = rings[r + 1];
    const auto nu = static_cast<int>(upper.size()), nl = static_cast<int>(lower.size());
    const double shift_upper = 0.5 * static_cast<double>(r % 2), shift_lower = 0.5 * static_cast<double>((r + 1) % 2);
    // Whichever ring's next vertex comes first going round closes the next triangle.
    for (int i = 0, j = 0; i < nu || j < nl;) {
      if (j >= nl || (i < nu && (i + 1 + shift_upper) / nu <= (j + 1 + shift_lower) / nl)) {
        if (nu > 1) triangles.emplace_back(upper[i % nu], lower[j % nl], upper[(i + 1) % nu]);
        ++i;
      } else {
        if (nl > 1) triangles.emplace_back(upper[i % nu], lower[j % nl], lower[(j + 1) % nl]);
        ++j;
      }
    }
  }
  Mesh mesh;
  mesh.positions.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t v = 0; v < points.size(); ++v) mesh.positions.row(static_cast<Eigen::Index>(v)) = points[v];
  mesh.triangles.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (std::size_t t = 0; t < triangles.size(); ++t) mesh.triangles.row(static_cast<Eigen::Index>(t)) = triangles[t];
  return mesh;
}

DeformerOptions multiresolution(Eigen::Index base_vertices) {
  DeformerOptions options;
  options.resolution = Resolution::Multiresolution;
  options.base_vertices = base_vertices;
  return options;
}

TEST(Relief, DisplacesAlongTheNormalsWithinItsBound) {
  const Shape bar = make_shape(ShapeKind::Bar, 16);
  const Mesh rest = subdivide(bar.mesh).mesh;
  Mesh unchanged = rest;
  add_relief(unchanged, 0.0);
  EXPECT_TRUE(unchanged.positions == rest.positions) << "amplitude 0 must leave the positions as they are";

  const double amplitude = 0.004, diagonal = bounding_box_diagonal(rest.positions);
  Mesh relief = rest;
  add_relief(relief, amplitude);
  const Eigen::MatrixXd normals = vertex_normals(rest.positions, rest.triangles);
  double largest = 0.0;
  for (Eigen::Index v = 0; v < rest.vertex_count(); ++v) {
    const Eigen::RowVector3d moved = relief.positions.row(v) - rest.positions.row(v);
    EXPECT_LT(moved.cross(Eigen::RowVector3d(normals.row(v))).norm(), 1e-12 * diagonal) << "vertex " << v << " moved off its normal";
    largest = std::max(largest, moved.norm());
  }
  EXPECT_LE(largest, 1.75 * amplitude * diagonal);
  EXPECT_GT(largest, 0.5 * amplitude * diagonal) << "the pattern should reach well above half its bound";
  EXPECT_THROW(add_relief(relief, -0.001), InputError);
  EXPECT_THROW(add_relief(relief, std::nan("")), InputError);
}

TEST(VertexNormals, AreUnitAndRadialOnASphere) {
  const Shape sphere = make_shape(ShapeKind::Sphere, 32);
  const Eigen::MatrixXd normals = vertex_normals(sphere.mesh.positions, sphere.mesh.triangles);
  const Eigen::RowVector3d center = sphere.mesh.positions.colwise().mean();
  for (Eigen::Index v = 0; v < normals.rows(); ++v) {
    EXPECT_NEAR(normals.row(v).norm(), 1.0, 1e-12);
    const Eigen::RowVector3d radial = (sphere.mesh.positions.row(v) - center).normalized();
    EXPECT_GT(normals.row(v).dot(radial), 0.99) << "vertex " << v;
  }
}

TEST(BaseMesh, KeepsTheTopologyAndTheFineVerticesBitForBit) {
  struct Case {
    const char* name;
    Mesh mesh;
  };
  const Case cases[] = {
      {"torus (genus 1)", torus(80, 24)},
      {"tube (two boundary loops)", torus(60, 20, true)},
      {"cactus", make_shape(ShapeKind::Cactus, 24).mesh},
      {"relief", bar_with_relief().mesh},
  };
  for (const auto& [name, mesh] : cases) {
    SCOPED_TRACE(name);
    const auto target = mesh.vertex_count() / 6;
    const BaseMesh base = simplify_to_base(mesh, target);
    const MeshTopology fine = mesh_topology(mesh), coarse = mesh_topology(base.mesh);
    EXPECT_TRUE(coarse.same_as(fine)) << coarse.describe() << " against " << fine.describe();
    EXPECT_LE(base.mesh.vertex_count(), target + target / 20) << "the collapses stopped well short of the target";
    ASSERT_EQ(base.fine_vertex.size(), static_cast<std::size_t>(base.mesh.vertex_count()));
    for (std::size_t j = 0; j < base.fine_vertex.size(); ++j) {
      if (j > 0) {
        EXPECT_LT(base.fine_vertex[j - 1], base.fine_vertex[j]);
      }
      ASSERT_TRUE((base.mesh.positions.row(static_cast<Eigen::Index>(j)).array() == mesh.positions.row(base.fine_vertex[j]).array()).all());
    }
    // Oriented like the mesh: every edge once in each direction (closed) or once (boundary), and
    // no triangle degenerate or folded against its fine surroundings.
    std::set<std::pair<int, int>> directed;
    for (Eigen::Index t = 0; t < base.mesh.triangle_count(); ++t) {
      for (int k = 0; k < 3; ++k) EXPECT_TRUE(directed.insert({base.mesh.triangles(t, k), base.mesh.triangles(t, (k + 1) % 3)}).second);
      const Eigen::Vector3d a = base.mesh.positions.row(base.mesh.triangles(t, 0)), b = base.mesh.positions.row(base.mesh.triangles(t, 1)),
                            c = base.mesh.positions.row(base.mesh.triangles(t, 2));
      EXPECT_GT((b - a).cross(c - a).norm(), 0.0);
    }
  }
}

TEST(BaseMesh, SimplifiedAsFarAsItGoesATorusKeepsItsHole) {
  // Asked for fewer vertices than any torus has (seven at least), the collapses stop where the
  // next one would close the hole or pinch the surface.
  for (const auto& [name, mesh] : {std::pair{"torus", torus(60, 12)}, std::pair{"tube", torus(40, 10, true)}}) {
    SCOPED_TRACE(name);
    const BaseMesh base = simplify_to_base(mesh, 4);
    EXPECT_TRUE(mesh_topology(base.mesh).same_as(mesh_topology(mesh))) << mesh_topology(base.mesh).describe();
    EXPECT_LT(base.mesh.vertex_count(), mesh.vertex_count() / 4) << "it went far";
  }
}

TEST(BaseMesh, TheSameBaseWhateverTheThreads) {
  // Large enough (68,000 vertices) for the collapses to run in slabs side by side.
  const Mesh mesh = torus(400, 170);
  const auto target = mesh.vertex_count() / 10;
  BaseMesh one;
  {
    const tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = simplify_to_base(mesh, target);
  }
  const BaseMesh all = simplify_to_base(mesh, target);
  EXPECT_EQ(all.fine_vertex, one.fine_vertex);
  EXPECT_EQ(all.mesh.triangles, one.mesh.triangles);
  EXPECT_TRUE(mesh_topology(all.mesh).same_as(mesh_topology(mesh)));
  EXPECT_LE(all.mesh.vertex_count(), target + target / 20);
}

TEST(BaseMesh, ReportsItsProgressOnTheCallingThreadAndBuildsTheSameBase) {
  const Mesh mesh = torus(400, 170);
  const auto target = mesh.vertex_count() / 10;
  const auto caller = std::this_thread::get_id();
  std::vector<double> shares;
  bool elsewhere = false;
  const BaseMesh reported = simplify_to_base(mesh, target, [&](double share) {
    elsewhere = elsewhere || std::this_thread::get_id() != caller;
    shares.push_back(share);
  });
  EXPECT_FALSE(elsewhere) << "progress comes on the thread that asked for the base";
  ASSERT_GE(shares.size(), 3u) << "one call a pass";
  EXPECT_TRUE(std::is_sorted(shares.begin(), shares.end()));
  EXPECT_GT(shares.front(), 0.0);
  EXPECT_LE(shares.back(), 1.0);
  // The base reaches the target within 5% (the test above), so nearly every collapse was done.
  const double done = static_cast<double>(mesh.vertex_count() - reported.mesh.vertex_count()) / static_cast<double>(mesh.vertex_count() - target);
  EXPECT_NEAR(shares.back(), std::min(done, 1.0), 1e-12);
  const BaseMesh quiet = simplify_to_base(mesh, target);
  EXPECT_EQ(reported.fine_vertex, quiet.fine_vertex);
  EXPECT_EQ(reported.mesh.triangles, quiet.mesh.triangles);
}

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

TEST(BaseMesh, AsLargeAsTheMeshIsTheMeshItself) {
  const Mesh mesh = torus(20, 10);
  const BaseMesh base = simplify_to_base(mesh, mesh.vertex_count());
  EXPECT_EQ(base.mesh.positions, mesh.positions);
  EXPECT_EQ(base.mesh.triangles, mesh.triangles);
}

TEST(DetailEncoding, TheRestBaseGivesBackTheMeshToTheLastBit) {
  const Relief relief = bar_with_relief();
  const BaseMesh base = simplify_to_base(relief.mesh, relief.mesh.vertex_count() / 10);
  const DetailEncoding encoding(relief.mesh, base);
  EXPECT_GT(encoding.largest_detail(), 0.0) << "a relief has detail to carry";
  Eigen::MatrixXd rebuilt;
  encoding.reconstruct(base.mesh.positions, rebuilt);
  EXPECT_TRUE((rebuilt.array() == relief.mesh.positions.array()).all());
}

TEST(DetailEncoding, ARigidMotionOfTheBaseMovesTheDetailRigidly) {
  const Relief relief = bar_with_relief();
  const BaseMesh base = simplify_to_base(relief.mesh, relief.mesh.vertex_count() / 10);
  const DetailEncoding encoding(relief.mesh, base);
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(2.1, Eigen::Vector3d(0.3, -0.8, 0.5).normalized()).toRotationMatrix();
  const Eigen::RowVector3d shift(3.0, -1.5, 7.25);
  const Eigen::MatrixXd moved_base = (base.mesh.positions * rotation.transpose()).rowwise() + shift;
  Eigen::MatrixXd rebuilt;
  encoding.reconstruct(moved_base, rebuilt);
  const Eigen::MatrixXd expected = (relief.mesh.positions * rotation.transpose()).rowwise() + shift;
  EXPECT_LE((rebuilt - expected).rowwise().norm().maxCoeff(), 1e-9 * relief.diagonal);
}

TEST(DetailEncoding, ARebuildWritesEveryVertexWhateverTheMatrixHeld) {
  // The rebuild goes triangle by triangle and writes each vertex where it is: a matrix of NaNs,
  // or one holding another rebuild, must come out as a fresh rebuild, bit for bit.
  const Relief relief = bar_with_relief();
  const BaseMesh base = simplify_to_base(relief.mesh, relief.mesh.vertex_count() / 10);
  const DetailEncoding encoding(relief.mesh, base);
  Eigen::MatrixXd bent = base.mesh.positions;
  for (Eigen::Index j = 0; j < bent.rows(); ++j) {
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.8 * bent(j, 2), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    bent.row(j) = (turn * bent.row(j).transpose()).transpose();
  }
  Eigen::MatrixXd alone;
  encoding.reconstruct(bent, alone);
  Eigen::MatrixXd reused = Eigen::MatrixXd::Constant(relief.mesh.vertex_count(), 3, std::numeric_limits<double>::quiet_NaN());
  encoding.reconstruct(bent, reused);
  EXPECT_TRUE((reused.array() == alone.array()).all());
  encoding.reconstruct(base.mesh.positions, reused);
  encoding.reconstruct(bent, reused);
  EXPECT_TRUE((reused.array() == alone.array()).all());
  // A base triangle squeezed to a point has no frame: its fine vertices keep their foot, finite.
  Eigen::MatrixXd squeezed = bent;
  for (int k = 1; k < 3; ++k) squeezed.row(base.mesh.triangles(0, k)) = squeezed.row(base.mesh.triangles(0, 0));
  encoding.reconstruct(squeezed, reused);
  EXPECT_TRUE(reused.allFinite());
  EXPECT_THROW(encoding.reconstruct(bent.topRows(bent.rows() - 1), reused), std::invalid_argument);
}

// The point of triangle (a, b, c) closest to p, found independently of the library's Voronoi
// regions: the projection onto the plane where it falls inside, else the closest of the three
// edges' closest points.
Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a, d = p - a;
  Eigen::Matrix2d gram;
  gram << e1.dot(e1), e1.dot(e2), e1.dot(e2), e2.dot(e2);
  const Eigen::Vector2d w = gram.ldlt().solve(Eigen::Vector2d(e1.dot(d), e2.dot(d)));
  if (w[0] >= 0 && w[1] >= 0 && w[0] + w[1] <= 1) return a + w[0] * e1 + w[1] * e2;
  auto on_segment = [&](const Eigen::Vector3d& from, const Eigen::Vector3d& to) -> Eigen::Vector3d {
    const double s = std::clamp((p - from).dot(to - from) / (to - from).squaredNorm(), 0.0, 1.0);
    return from + s * (to - from);
  };
  Eigen::Vector3d best = on_segment(a, b);
  for (const Eigen::Vector3d& q : {on_segment(b, c), on_segment(c, a)}) {
    if ((q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
  }
  return best;
}

TEST(DetailEncoding, EachFootIsTheClosestFacingPointAroundTheNearestBaseVertex) {
  // The documented rule, checked against a search written here: the nearest base vertex along
  // the fine surface (fewest edges; a breadth-first search from every base vertex, in index
  // order), then among the base triangles around it those facing the way the fine surface does
  // first, and the closest of them. A wider search may only find a foot as good or better.
  const Relief relief = bar_with_relief();
  const Mesh& fine = relief.mesh;
  const BaseMesh base = simplify_to_base(fine, fine.vertex_count() / 10);
  const DetailEncoding encoding(fine, base);
  const auto n = static_cast<std::size_t>(fine.vertex_count());
  std::vector<std::vector<int>> fine_fan(n), base_fan(static_cast<std::size_t>(base.mesh.vertex_count()));
  for (Eigen::Index t = 0; t < fine.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) fine_fan[static_cast<std::size_t>(fine.triangles(t, k))].push_back(static_cast<int>(t));
  }
  for (Eigen::Index t = 0; t < base.mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) base_fan[static_cast<std::size_t>(base.mesh.triangles(t, k))].push_back(static_cast<int>(t));
  }
  std::vector<int> nearest(n, -1), queue;
  for (std::size_t v = 0; v < n; ++v) {
    if (const int j = encoding.base_vertex(static_cast<int>(v)); j >= 0) {
      nearest[v] = j;
      queue.push_back(static_cast<int>(v));
    }
  }
  for (std::size_t head = 0; head < queue.size(); ++head) {
    for (const int t : fine_fan[static_cast<std::size_t>(queue[head])]) {
      for (int k = 0; k < 3; ++k) {
        const auto w = static_cast<std::size_t>(fine.triangles(t, k));
        if (nearest[w] < 0) {
          nearest[w] = nearest[static_cast<std::size_t>(queue[head])];
          queue.push_back(static_cast<int>(w));
        }
      }
    }
  }
  Eigen::MatrixXd foot(fine.vertex_count(), 3);
  for (int k = 0; k < 3; ++k) foot.col(k) = encoding.interpolate(base.mesh.positions.col(k));
  auto corner = [&](int t, int k) -> Eigen::Vector3d { return base.mesh.positions.row(base.mesh.triangles(t, k)).transpose(); };
  auto area = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) { return Eigen::Vector3d((b - a).cross(c - a)); };
  const double tolerance = 1e-12 * relief.diagonal;
  int checked = 0, facing_feet = 0;
  for (std::size_t v = 0; v < n; ++v) {
    if (encoding.base_vertex(static_cast<int>(v)) >= 0) continue;
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    for (const int t : fine_fan[v]) {
      const Eigen::Vector3d a = fine.positions.row(fine.triangles(t, 0)), b = fine.positions.row(fine.triangles(t, 1)),
                            c = fine.positions.row(fine.triangles(t, 2));
      normal += area(a, b, c);
    }
    const Eigen::Vector3d p = fine.positions.row(static_cast<Eigen::Index>(v)).transpose();
    const auto corners = encoding.foot_corners(static_cast<int>(v));
    ASSERT_GE(corners[0], 0) << "vertex " << v << " has no foot";
    const Eigen::Vector3d foot_area = area(base.mesh.positions.row(corners[0]), base.mesh.positions.row(corners[1]), base.mesh.positions.row(corners[2]));
    const bool foot_faces = foot_area.dot(normal) > 0.0;
    facing_feet += foot_faces ? 1 : 0;
    const double foot_distance = (foot.row(static_cast<Eigen::Index>(v)).transpose() - p).norm();
    for (const int t : base_fan[static_cast<std::size_t>(nearest[v])]) {
      const Eigen::Vector3d a = corner(t, 0), b = corner(t, 1), c = corner(t, 2);
      if (!(area(a, b, c).squaredNorm() > 0.0)) continue;
      const bool faces = area(a, b, c).dot(normal) > 0.0;
      if (faces) {
        EXPECT_TRUE(foot_faces) << "vertex " << v << ": base triangle " << t << " faces its way, its foot's does not";
      }
      if (faces == foot_faces) {
        EXPECT_LE(foot_distance, (closest_on_triangle(p, a, b, c) - p).norm() + tolerance) << "vertex " << v << ", base triangle " << t;
      }
    }
    ++checked;
  }
  EXPECT_GT(checked, fine.vertex_count() / 2);
  EXPECT_GT(facing_feet, checked * 9 / 10) << "a relief this shallow faces its base almost everywhere";
}

TEST(DetailEncoding, ValuesAreCarriedLinearly) {
  // A linear function on the base, interpolated over the feet, is that function at each foot:
  // at base vertices exactly, elsewhere within the detail's length times its slope.
  const Relief relief = bar_with_relief();
  const BaseMesh base = simplify_to_base(relief.mesh, relief.mesh.vertex_count() / 10);
  const DetailEncoding encoding(relief.mesh, base);
  const Eigen::Vector3d slope(0.2, -0.7, 0.4);
  const Eigen::VectorXd fine = encoding.interpolate(base.mesh.positions * slope);
  const Eigen::VectorXd exact = relief.mesh.positions * slope;
  for (Eigen::Index v = 0; v < fine.size(); ++v) {
    if (encoding.base_vertex(static_cast<int>(v)) >= 0) {
      EXPECT_EQ(fine[v], exact[v]);
    } else {
      EXPECT_LE(std::abs(fine[v] - exact[v]), encoding.largest_detail() * slope.norm() + 1e-12);
    }
  }
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

TEST(DetailEncoding, CoordinatesNearZeroComeBackToTheLastBitToo) {
  // Where a rest coordinate is tiny beside the base's (1e-19 of a unit mesh), the reconstruction's
  // rounding is larger than the coordinate itself, and rest − reconstruction rounds or has more
  // bits than the float the encoding keeps it in: those vertices must still come back exactly,
  // and move like their neighbours.
  Relief relief = bar_with_relief();
  const double limit = 1e-3 * relief.diagonal;
  int tiny = 0;
  for (Eigen::Index v = 0; v < relief.mesh.vertex_count(); ++v) {
    for (int k = 0; k < 3; ++k) {
      const double x = relief.mesh.positions(v, k);
      if (x != 0.0 && std::abs(x) < limit) {
        relief.mesh.positions(v, k) = std::copysign(1e-19 * (1 + (v % 7) / 7.0), x);
        ++tiny;
      }
    }
  }
  ASSERT_GT(tiny, 20);
  const BaseMesh base = simplify_to_base(relief.mesh, relief.mesh.vertex_count() / 10);
  const DetailEncoding encoding(relief.mesh, base);
  Eigen::MatrixXd rebuilt;
  encoding.reconstruct(base.mesh.positions, rebuilt);
  EXPECT_TRUE((rebuilt.array() == relief.mesh.positions.array()).all());
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 0.9, -0.4).normalized()).toRotationMatrix();
  encoding.reconstruct(base.mesh.positions * rotation.transpose(), rebuilt);
  EXPECT_LE((rebuilt - relief.mesh.positions * rotation.transpose()).rowwise().norm().maxCoeff(), 1e-9 * relief.diagonal);
  // The vertices kept apart (their rest inexact) are placed as the rebuild of some vertices places them.
  std::vector<int> every(static_cast<std::size_t>(relief.mesh.vertex_count()));
  std::iota(every.begin(), every.end(), 0);
  Eigen::MatrixXd one_by_one = Eigen::MatrixXd::Zero(relief.mesh.vertex_count(), 3);
  encoding.reconstruct(base.mesh.positions * rotation.transpose(), one_by_one, every);
  EXPECT_TRUE((one_by_one.array() == rebuilt.array()).all());
  for (Eigen::Index v = 0; v < relief.mesh.vertex_count(); ++v) EXPECT_GE(encoding.base_vertex(static_cast<int>(v)), -1);
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

// The relief bar's encoding against a base of a tenth of its vertices, that base bent, and the
// whole rebuild on it.
struct BentEncoding {
  Relief relief;
  DetailEncoding encoding;
  Eigen::MatrixXd bent, whole;
};
BentEncoding bent_encoding() {
  BentEncoding result;
  result.relief = bar_with_relief();
  const BaseMesh base = simplify_to_base(result.relief.mesh, result.relief.mesh.vertex_count() / 10);
  result.encoding = DetailEncoding(result.relief.mesh, base);
  result.bent = base.mesh.positions;
  Eigen::MatrixXd& bent = result.bent;
  for (Eigen::Index j = 0; j < bent.rows(); ++j) bent.row(j) += Eigen::RowVector3d(0.3 * bent(j, 2) * bent(j, 2), 0.0, 0.1 * bent(j, 0));
  result.encoding.reconstruct(bent, result.whole);
  return result;
}

TEST(DetailEncoding, SomeVerticesAreRebuiltAsTheWholeRebuildDoesAndOnlyThey) {
  const auto [relief, encoding, bent, whole] = bent_encoding();
  const std::vector<int> some{0, 3, 17, 4, static_cast<int>(relief.mesh.vertex_count()) - 1};  // any order
  Eigen::MatrixXd positions = Eigen::MatrixXd::Constant(relief.mesh.vertex_count(), 3, 42.0);
  encoding.reconstruct(bent, positions, some);
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    const bool asked = std::find(some.begin(), some.end(), static_cast<int>(v)) != some.end();
    if (asked) EXPECT_TRUE((positions.row(v).array() == whole.row(v).array()).all()) << v;
    else EXPECT_TRUE((positions.row(v).array() == 42.0).all()) << v;
  }
  // Every vertex one at a time (compiled for the baseline) gives the whole rebuild's bits (the
  // AVX2 clone where the CPU has it).
  std::vector<int> every(static_cast<std::size_t>(relief.mesh.vertex_count()));
  std::iota(every.begin(), every.end(), 0);
  positions.setConstant(42.0);
  encoding.reconstruct(bent, positions, every);
  EXPECT_TRUE((positions.array() == whole.array()).all());
  const std::vector<int> outside{static_cast<int>(relief.mesh.vertex_count())};
  EXPECT_THROW(encoding.reconstruct(bent, positions, outside), std::invalid_argument);
  Eigen::MatrixXd small(3, 3);
  EXPECT_THROW(encoding.reconstruct(bent, small, some), std::invalid_argument);
}

// A rebuild that skips the foot triangles whose vertices are all in a set (the constrained ones,
// which the deformer places itself) leaves exactly those vertices as they were, and gives every
// other vertex the whole rebuild's bits. Which triangles qualify is worked out here from the feet.
TEST(DetailEncoding, TrianglesWhoseVerticesAreAllGivenAreSkippedAndNothingElse) {
  const auto [relief, encoding, bent, whole] = bent_encoding();
  // The vertices of the bar's upper half, and a few scattered below.
  const double middle = 0.5 * (relief.mesh.positions.col(2).minCoeff() + relief.mesh.positions.col(2).maxCoeff());
  std::vector<int> given;
  for (Eigen::Index v = 0; v < relief.mesh.vertex_count(); ++v) {
    if (relief.mesh.positions(v, 2) > middle || v % 7 == 0) given.push_back(static_cast<int>(v));
  }
  std::set<int> in_set(given.begin(), given.end());
  // A vertex with a foot and no base vertex of its own is rebuilt from its foot triangle; the
  // triangle is skipped when every such vertex on it is given.
  std::map<std::array<int, 3>, bool> all_given;
  auto key_of = [&](int v) {
    std::array<int, 3> corners = encoding.foot_corners(v);
    std::sort(corners.begin(), corners.end());
    return corners;
  };
  auto rebuilt_from_foot = [&](int v) { return encoding.base_vertex(v) < 0 && encoding.foot_corners(v)[0] >= 0; };
  for (int v = 0; v < static_cast<int>(relief.mesh.vertex_count()); ++v) {
    if (!rebuilt_from_foot(v)) continue;
    const auto [at, inserted] = all_given.emplace(key_of(v), true);
    at->second = at->second && in_set.count(v) > 0;
  }
  const std::vector<char> skip = encoding.triangles_only_of(given);
  const auto skipped = std::count(skip.begin(), skip.end(), 1);
  EXPECT_EQ(skipped, std::count_if(all_given.begin(), all_given.end(), [](const auto& entry) { return entry.second; }));
  EXPECT_GT(skipped, 0);
  Eigen::MatrixXd positions = Eigen::MatrixXd::Constant(relief.mesh.vertex_count(), 3, 42.0);
  encoding.reconstruct(bent, positions, skip);
  int kept = 0;
  for (int v = 0; v < static_cast<int>(positions.rows()); ++v) {
    const bool skipped_vertex = rebuilt_from_foot(v) && all_given.at(key_of(v));
    kept += skipped_vertex ? 1 : 0;
    if (skipped_vertex) EXPECT_TRUE((positions.row(v).array() == 42.0).all()) << v;
    else EXPECT_TRUE((positions.row(v).array() == whole.row(v).array()).all()) << v;
  }
  EXPECT_GT(kept, 0);
  EXPECT_THROW(encoding.reconstruct(bent, positions, std::vector<char>(skip.size() - 1, 0)), std::invalid_argument);
  Eigen::MatrixXd small(3, 3);
  EXPECT_THROW(encoding.reconstruct(bent, small, skip), std::invalid_argument);
  EXPECT_THROW(encoding.triangles_only_of(std::vector<int>{-1}), std::invalid_argument);
}

TEST(Multiresolution, AHandleSmallerThanABaseTriangleReachesTheBase) {
  const Relief relief = bar_with_relief();
  const auto operators = MeshOperators::of(relief.mesh, Resolution::Multiresolution, relief.mesh.vertex_count() / 20);
  const DetailEncoding& encoding = operators->multiresolution->encoding;
  // A handle vertex near the top that the base does not have.
  int lone = -1;
  for (const int v : relief.constraints.handles[0]) {
    if (encoding.base_vertex(v) < 0) {
      lone = v;
      break;
    }
  }
  ASSERT_GE(lone, 0);
  EditConstraints constraints{relief.constraints.fixed, {{lone}}, {}};
  const EditConstraints base = base_constraints(constraints, encoding);
  ASSERT_EQ(base.handles.size(), 1u);
  EXPECT_FALSE(base.handles[0].empty());
  for (const int j : base.handles[0]) {
    const auto corners = encoding.foot_corners(lone);
    EXPECT_NE(std::find(corners.begin(), corners.end(), j), corners.end());
  }
  Deformer deformer(relief.mesh, constraints, operators, multiresolution(relief.mesh.vertex_count() / 20));
  EXPECT_EQ(deformer.operators().get(), operators.get()) << "the operators given are used, not built again";
  const HandleTransform pull = HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero(), 0.0, 1.0,
                                                            Eigen::Vector3d(0, 0, 0.05 * relief.diagonal));
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&pull, 1), positions);
  EXPECT_TRUE((positions.row(lone).array() == pull.apply(relief.mesh.positions.row(lone).transpose()).transpose().array()).all());
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

TEST(BaseMesh, KeepsMoreVerticesWhereTheMeshIsDenser) {
  // Where a scan is dense its triangles are small, and a base triangle many times their size lets
  // the deformation bend the fine surface inside it, which folds them. The northern half has four
  // times the vertices per area. A base that went by the distance to the planes alone would spend
  // its vertices evenly over the equally curved halves, so each of its northern vertices would
  // stand for about four times as many fine ones as a southern one (measured: 3.89–4.23 on these
  // spheres). With the cost raised where the triangles are smaller than the mean, it stands for
  // 3.49–3.66.
  for (const double southern_edge : {0.05, 0.06, 0.08}) {
    SCOPED_TRACE(southern_edge);
    const Mesh mesh = sphere_denser_in_the_north(southern_edge);
    ASSERT_EQ(mesh_topology(mesh).euler_characteristic(), 2);
    const BaseMesh base = simplify_to_base(mesh, mesh.vertex_count() / 8);
    EXPECT_TRUE(mesh_topology(base.mesh).same_as(mesh_topology(mesh)));
    auto northern = [](const Eigen::MatrixXd& positions) { return static_cast<double>((positions.col(2).array() > 0.0).count()); };
    const double fine_north = northern(mesh.positions), base_north = northern(base.mesh.positions);
    const double fine_south = static_cast<double>(mesh.vertex_count()) - fine_north, base_south = static_cast<double>(base.mesh.vertex_count()) - base_north;
    ASSERT_GT(fine_north, 3.0 * fine_south) << "the north is the denser half";
    const double per_base_vertex_north = fine_north / base_north, per_base_vertex_south = fine_south / base_south;
    EXPECT_LT(per_base_vertex_north / per_base_vertex_south, 3.8) << base_north << " base vertices in the north, " << base_south << " in the south";
  }
}

TEST(BaseMesh, TheBoundaryStays) {
  // Two triangles: every vertex is on the boundary, so nothing collapses.
  Mesh square;
  square.positions.resize(4, 3);
  square.positions << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  square.triangles.resize(2, 3);
  square.triangles << 0, 1, 2, 0, 2, 3;
  const BaseMesh base = simplify_to_base(square, 3);
  EXPECT_EQ(base.mesh.vertex_count(), 4) << "the boundary stays";
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

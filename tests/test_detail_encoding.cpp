// The detail encoding of multiresolution editing: at rest it gives the mesh back to the last bit,
// a rigid motion of the base moves the detail rigidly, each foot is the closest facing point
// around the nearest base vertex, and a rebuild of some vertices or some triangles does what the
// whole rebuild does for them and nothing else.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>
#include <set>
#include <vector>

#include "hdeform/errors.h"
#include "hdeform/multiresolution.h"
#include "hdeform/subdivision.h"
#include "multiresolution_meshes.h"
#include "test_support.h"

namespace hdeform {
namespace {

using test::bar_with_relief;
using test::Relief;

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

}  // namespace
}  // namespace hdeform

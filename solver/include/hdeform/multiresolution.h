#pragma once
/// @file
/// Multiresolution editing (Kobbelt et al. 1998, "Interactive multi-resolution modeling on
/// arbitrary meshes"; Botsch & Sorkine 2008, §5): a scan of millions of triangles is deformed
/// through a base mesh of a manageable size, and its fine detail is carried along as displacements
/// in local frames of the base. The harmonic guidance field is smooth by construction, which is
/// what a base mesh represents well.
///
/// The base's vertices are fine vertices (the simplifier only collapses edges), so every base vertex
/// sits exactly where its fine vertex does, and a fine vertex set reaches the base through them.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/mesh.h"

namespace hdeform {

/// Meshes with at least this many vertices are edited on a base mesh unless the exact solve is
/// asked for: at 1.5M vertices the exact set-up takes 25–30 s and a drag 200 ms on two cores.
inline constexpr Eigen::Index kMultiresolutionFrom = 500'000;
/// The base's default size: the Buddha's scale, where a drag stays interactive.
inline constexpr Eigen::Index kDefaultBaseVertices = 150'000;

/// How a mesh's topology reads: what simplification must keep.
struct MeshTopology {
  Eigen::Index vertices = 0;  ///< referenced by a triangle
  Eigen::Index edges = 0;
  Eigen::Index triangles = 0;
  Eigen::Index components = 0;       ///< of referenced vertices, joined by triangles
  Eigen::Index boundary_edges = 0;   ///< in one triangle
  Eigen::Index nonmanifold_edges = 0;  ///< in more than two
  /// V − E + F.
  Eigen::Index euler_characteristic() const { return vertices - edges + triangles; }
  /// Whether two meshes have the same Euler characteristic, components, boundary edges and
  /// non-manifold edges (what a base must keep).
  bool same_as(const MeshTopology& other) const;
  std::string describe() const;  ///< "V vertices, χ = …, k components, b boundary edges"
};
/// The topology of a mesh: its counts, components, boundary and non-manifold edges.
MeshTopology mesh_topology(const Mesh& mesh);

/// A base mesh: a simplified copy whose vertices are vertices of the fine mesh.
struct BaseMesh {
  Mesh mesh;                     ///< positions: those of its fine vertices, bit for bit
  std::vector<int> fine_vertex;  ///< base vertex → its fine vertex, ascending
  double simplification_error = 0.0;  ///< the largest collapse's quadric error, over the bounding-box diagonal
};

/// A base of about `target_vertices` vertices by quadric-error halfedge collapses that keep the
/// topology (the link condition; boundary vertices stay), checked against the fine mesh's after.
/// Fewer collapses where no more are allowed. A connected component that must keep more than its
/// share of the target (in proportion to its vertices), such as a scan's islands of a few
/// triangles, keeps them on top of the target rather than at the other components' cost. Throws SolveError if the topology changed anyway.
/// A target at or above the fine mesh's size gives the fine mesh itself. `collapsed_share`, if
/// given, is called on the calling thread after each pass of collapses with the share of the
/// collapses to the target done so far, 0 to 1 (progress: at 13 million triangles the collapses
/// take about eighteen seconds).
BaseMesh simplify_to_base(const Mesh& fine, Eigen::Index target_vertices, const std::function<void(double)>& collapsed_share = {});

/// Each fine vertex once against the base at rest: its foot point on a base triangle (that
/// triangle and barycentric coordinates) and the detail vector from the foot to the vertex in the
/// triangle's orthonormal frame (first edge, the normal, their cross product). The foot is the
/// closest point among the base triangles around the base vertex that is nearest along the
/// fine surface, fewest edges away (so thin parts never borrow detail from the other side),
/// preferring triangles that face the way the fine surface does.
class DetailEncoding {
 public:
  DetailEncoding() = default;
  /// Encodes every fine vertex against the base: its foot on a base triangle and its detail vector
  /// in that triangle's frame.
  DetailEncoding(const Mesh& fine, const BaseMesh& base);

  /// The number of fine vertices.
  Eigen::Index fine_count() const { return static_cast<Eigen::Index>(foot_triangle_.size()); }
  /// The number of base vertices.
  Eigen::Index base_count() const { return base_count_; }

  /// The fine mesh on a deformed base (base_positions: the base's vertex count × 3): each fine
  /// vertex moves by the change of its foot plus its detail in the triangle's frame, so with the
  /// base at rest every vertex is its rest position to the last bit, and a rigid motion of the
  /// base moves it rigidly. Base vertices take the base's positions. Parallel, and allocation-free
  /// once `fine_positions` has the fine size; one encoding may serve several rebuilds at once.
  void reconstruct(const Eigen::MatrixXd& base_positions, Eigen::MatrixXd& fine_positions) const;
  /// The same for the fine `vertices` alone (say, those a proxy draws), each row the bits the
  /// whole rebuild gives it; the other rows keep what they held (`fine_positions` must have the
  /// fine size).
  void reconstruct(const Eigen::MatrixXd& base_positions, Eigen::MatrixXd& fine_positions, std::span<const int> vertices) const;
  /// The foot triangles all of whose fine vertices are among `vertices` (say, the constrained ones,
  /// which the caller puts where their constraints say), marked 1: a whole rebuild may skip them.
  std::vector<char> triangles_only_of(std::span<const int> vertices) const;
  /// The whole rebuild, except the vertices of the foot triangles `skip` marks (from
  /// triangles_only_of), which keep what they held.
  void reconstruct(const Eigen::MatrixXd& base_positions, Eigen::MatrixXd& fine_positions, const std::vector<char>& skip) const;

  /// Per-vertex values of the base carried to the fine mesh, linearly over the foot triangles.
  Eigen::VectorXd interpolate(const Eigen::VectorXd& base_values) const;

  /// The base vertex of a fine vertex, or −1 when it has none.
  int base_vertex(int fine_vertex) const { return std::max(base_of_fine_[static_cast<std::size_t>(fine_vertex)], -1); }
  /// The corners (base vertices) of a fine vertex's foot triangle; all −1 for a vertex no triangle
  /// references.
  std::array<int, 3> foot_corners(int fine_vertex) const;
  /// The barycentric weights of those corners at the vertex's foot; zeros for a base vertex and
  /// for a vertex no triangle references.
  std::array<double, 3> foot_weights(int fine_vertex) const;
  /// The largest distance from a fine vertex to its foot (the detail's largest length).
  double largest_detail() const { return largest_detail_; }

 private:
  struct FineRow;
  void check_base(const Eigen::MatrixXd& base_positions) const;
  void rebuild(const Eigen::MatrixXd& base_positions, Eigen::MatrixXd& fine_positions, const char* skip) const;
  // A fine vertex's position from its row and its foot triangle, as the whole rebuild makes it.
  Eigen::Vector3d position_of(const FineRow& row, Eigen::Index triangle, const Eigen::MatrixXd& base_positions) const;

  Eigen::Index base_count_ = 0;
  Eigen::MatrixXi base_triangles_;
  std::vector<int> base_of_fine_;  ///< −1: not a base vertex
  std::vector<int> fine_of_base_;  ///< base vertex → its fine vertex
  std::vector<int> foot_triangle_;  ///< −1: unreferenced, kept at rest
  /// What the rebuild reads of a fine vertex that is not a base vertex, in one row: a rebuild of
  /// millions of vertices is bound by the bytes it reads.
  struct FineRow {
    double wb = 0.0, wc = 0.0;  ///< weights of the foot triangle's corners 1 and 2
    /// In the foot triangle's frame; for a vertex no triangle references, its rest position.
    std::array<double, 3> detail{};
    /// Added to the reconstruction: the rest position minus the reconstruction's own arithmetic
    /// on the rest base, so that the rest base gives back the rest positions to the last bit. A
    /// few ulps, so a float holds it exactly; NaN where it does not, or where the sum rounds (a
    /// coordinate near zero): then the vertex is in inexact_rest_.
    std::array<float, 3> correction{};
    int vertex = -1;  ///< the fine vertex
  };
  /// By foot triangle (the rows of triangle t: triangle_rows_[t] up to triangle_rows_[t + 1]),
  /// so that a rebuild makes each triangle's map once and uses it at once; then the vertices no
  /// triangle references.
  std::vector<FineRow> rows_;
  std::vector<int> triangle_rows_;
  std::vector<int> row_of_fine_;  ///< −1 for a base vertex
  /// A vertex whose rest position is not its rest reconstruction plus a float's correction:
  /// rebuilt as rest + (now − rest reconstruction). By vertex.
  struct InexactRest {
    int vertex;
    Eigen::Vector3d rest, rest_reconstruction;
  };
  std::vector<InexactRest> inexact_rest_;
  double largest_detail_ = 0.0;
};

/// A fine edit's sets carried to the base (base_constraints).
struct BaseConstraints {
  EditConstraints constraints;
  /// For the fixed set, then each handle: how many of its fine vertices lie in patches that hold no
  /// base vertex at all, every corner of their feet belonging to other sets. The base moves freely
  /// under such a patch while its fine vertices stay where the set says.
  std::vector<std::size_t> unheld_vertices;
};

/// A fine edit's sets on the base: a base vertex belongs to a set when its fine vertex does. Each
/// connected patch of a set (over the fine triangles' edges) that holds none of the base's vertices
/// (a patch smaller than a base triangle) takes, for each of its vertices, the corner of the foot
/// triangle nearest the foot (of the largest weight), where no other set holds it; where other sets
/// hold all of those, one of its feet's other corners. The region of interest is carried vertex by
/// vertex, widened by the corners of the feet of its vertices that are not the base's.
BaseConstraints base_constraints(const EditConstraints& fine, const Eigen::MatrixXi& fine_triangles, const DetailEncoding& encoding);

}  // namespace hdeform

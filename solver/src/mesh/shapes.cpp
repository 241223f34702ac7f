#include "hdeform/shapes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <unordered_map>
#include <vector>

#include "hdeform/errors.h"

namespace hdeform {
namespace {

using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

class MeshBuilder {
 public:
  int add_point(const Vector3d& p) {
    points_.push_back(p);
    return static_cast<int>(points_.size()) - 1;
  }
  Vector3d& point(int index) { return points_[static_cast<std::size_t>(index)]; }
  void add_triangle(int a, int b, int c) { triangles_.push_back({a, b, c}); }
  // Counter-clockwise quad a-b-c-d, split along its shorter diagonal.
  void add_quad(int a, int b, int c, int d) {
    if ((point(a) - point(c)).squaredNorm() <= (point(b) - point(d)).squaredNorm()) {
      add_triangle(a, b, c);
      add_triangle(a, c, d);
    } else {
      add_triangle(a, b, d);
      add_triangle(b, c, d);
    }
  }

  // Moves the given vertices towards the mean of their neighbours: rounds a crease.
  void smooth(const std::vector<int>& vertices, int iterations, double step) {
    std::vector<std::vector<int>> neighbours(points_.size());
    for (const auto& t : triangles_) {
      for (int k = 0; k < 3; ++k) neighbours[static_cast<std::size_t>(t[k])].push_back(t[(k + 1) % 3]);
    }
    std::vector<Vector3d> moved(vertices.size());
    for (int iteration = 0; iteration < iterations; ++iteration) {
      for (std::size_t k = 0; k < vertices.size(); ++k) {
        const auto& around = neighbours[static_cast<std::size_t>(vertices[k])];
        Vector3d mean = Vector3d::Zero();
        for (const int v : around) mean += point(v);
        mean /= static_cast<double>(around.size());
        moved[k] = point(vertices[k]) + step * (mean - point(vertices[k]));
      }
      for (std::size_t k = 0; k < vertices.size(); ++k) point(vertices[k]) = moved[k];
    }
  }

  // The mesh without points that no triangle uses, in creation order.
  Mesh build() const {
    std::vector<int> index(points_.size(), -1);
    for (const auto& t : triangles_) {
      for (const int v : t) index[static_cast<std::size_t>(v)] = 0;
    }
    int next = 0;
    for (auto& i : index) {
      if (i == 0) i = next++;
    }
    Mesh mesh;
    mesh.positions.resize(next, 3);
    for (std::size_t v = 0; v < points_.size(); ++v) {
      if (index[v] >= 0) mesh.positions.row(index[v]) = points_[v];
    }
    mesh.triangles.resize(static_cast<Eigen::Index>(triangles_.size()), 3);
    for (std::size_t t = 0; t < triangles_.size(); ++t) {
      for (int k = 0; k < 3; ++k) mesh.triangles(static_cast<Eigen::Index>(t), k) = index[static_cast<std::size_t>(triangles_[t][k])];
    }
    return mesh;
  }

 private:
  std::vector<Vector3d> points_;
  std::vector<std::array<int, 3>> triangles_;
};

// The surface of a box of cells[0]×cells[1]×cells[2] lattice cells; `place` maps lattice points.
template <class Place>
void add_lattice_box(MeshBuilder& builder, const std::array<int, 3>& cells, Place place) {
  std::unordered_map<std::int64_t, int> ids;
  auto vertex = [&](const std::array<int, 3>& c) {
    const std::int64_t key = (static_cast<std::int64_t>(c[0]) * (cells[1] + 1) + c[1]) * (cells[2] + 1) + c[2];
    const auto [it, inserted] = ids.try_emplace(key, 0);
    if (inserted) it->second = builder.add_point(place(c));
    return it->second;
  };
  // Each face: its fixed axis, whether at the far side, and axes u, v with u × v outward.
  struct Face {
    int fixed;
    bool far;
    int u;
    int v;
  };
  constexpr Face kFaces[6] = {{0, false, 2, 1}, {0, true, 1, 2}, {1, false, 0, 2},
                              {1, true, 2, 0},  {2, false, 1, 0}, {2, true, 0, 1}};
  for (const Face& face : kFaces) {
    for (int a = 0; a < cells[static_cast<std::size_t>(face.u)]; ++a) {
      for (int b = 0; b < cells[static_cast<std::size_t>(face.v)]; ++b) {
        auto corner = [&](int du, int dv) {
          std::array<int, 3> c{};
          c[static_cast<std::size_t>(face.fixed)] = face.far ? cells[static_cast<std::size_t>(face.fixed)] : 0;
          c[static_cast<std::size_t>(face.u)] = a + du;
          c[static_cast<std::size_t>(face.v)] = b + dv;
          return vertex(c);
        };
        builder.add_quad(corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
      }
    }
  }
}

std::vector<int> vertices_where(const Mesh& mesh, auto predicate) {
  std::vector<int> selected;
  for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
    if (predicate(Vector3d(mesh.positions.row(v)))) selected.push_back(static_cast<int>(v));
  }
  return selected;
}

HandleTransform rotation_about(const Vector3d& axis, const Vector3d& pivot, double degrees, const Vector3d& shift = Vector3d::Zero()) {
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(degrees * kPi / 180.0, axis.normalized()).toRotationMatrix();
  Eigen::Matrix<double, 3, 4> affine;
  affine << rotation, pivot - rotation * pivot + shift;
  return HandleTransform::from_affine(affine);
}

Shape make_bar(int resolution) {
  constexpr double kWidth = 0.16;
  constexpr double kLength = 1.0;
  const int across = std::max(2, resolution / 4);  // resolution counts segments around
  const int along = std::max(1, static_cast<int>(std::lround(across * kLength / kWidth)));
  MeshBuilder builder;
  add_lattice_box(builder, {across, across, along}, [&](const std::array<int, 3>& c) {
    return Vector3d(kWidth * (static_cast<double>(c[0]) / across - 0.5), kWidth * (static_cast<double>(c[1]) / across - 0.5),
                    kLength * c[2] / along);
  });
  Shape shape{builder.build(), {}, {}};
  shape.demo_constraints.fixed = vertices_where(shape.mesh, [](const Vector3d& p) { return p.z() <= 0.05 * kLength + 1e-12; });
  shape.demo_constraints.handles = {vertices_where(shape.mesh, [](const Vector3d& p) { return p.z() >= 0.95 * kLength - 1e-12; })};
  shape.demo_transform = HandleTransform::about_pivot(Vector3d::UnitZ(), Vector3d::Zero(), 135.0 * kPi / 180.0);
  return shape;
}

Shape make_sphere(int resolution) {
  constexpr double kRadius = 0.5;
  const int cells = std::max(2, resolution / 4);
  MeshBuilder builder;
  add_lattice_box(builder, {cells, cells, cells}, [&](const std::array<int, 3>& c) {
    // Cube to sphere with nearly uniform cells (no poles).
    const double x = 2.0 * c[0] / cells - 1.0, y = 2.0 * c[1] / cells - 1.0, z = 2.0 * c[2] / cells - 1.0;
    const double sx = x * std::sqrt(1.0 - y * y / 2.0 - z * z / 2.0 + y * y * z * z / 3.0);
    const double sy = y * std::sqrt(1.0 - z * z / 2.0 - x * x / 2.0 + z * z * x * x / 3.0);
    const double sz = z * std::sqrt(1.0 - x * x / 2.0 - y * y / 2.0 + x * x * y * y / 3.0);
    return Vector3d(kRadius * sx, kRadius * sy, kRadius * sz);
  });
  Shape shape{builder.build(), {}, {}};
  shape.demo_constraints.fixed = vertices_where(shape.mesh, [](const Vector3d& p) { return p.z() <= -0.35; });
  shape.demo_constraints.handles = {vertices_where(shape.mesh, [](const Vector3d& p) { return p.z() >= 0.4; })};
  shape.demo_transform = rotation_about(Vector3d::UnitY(), Vector3d(0, 0, 0.45), 25.0, Vector3d(0.1, 0.0, 0.25));
  return shape;
}

// Lattice points (a, b) around the border of an m×m square, counter-clockwise from (0, 0).
std::vector<std::array<int, 2>> square_border(int m) {
  std::vector<std::array<int, 2>> border;
  for (int a = 0; a < m; ++a) border.push_back({a, 0});
  for (int b = 0; b < m; ++b) border.push_back({m, b});
  for (int a = m; a > 0; --a) border.push_back({a, m});
  for (int b = m; b > 0; --b) border.push_back({0, b});
  return border;
}

// The unit square [−1, 1]² onto the unit disk; the border lands on the circle.
Eigen::Vector2d square_to_disk(int a, int b, int m) {
  const double x = 2.0 * a / m - 1.0, y = 2.0 * b / m - 1.0;
  return {x * std::sqrt(1.0 - y * y / 2.0), y * std::sqrt(1.0 - x * x / 2.0)};
}

Shape make_cylinder(int resolution) {
  constexpr double kRadius = 0.12;
  constexpr double kHeight = 1.0;
  const int m = std::max(2, resolution / 4);
  const auto border = square_border(m);
  const int around = static_cast<int>(border.size());
  const int rows = std::max(1, static_cast<int>(std::lround(kHeight / (2.0 * kPi * kRadius / around))));
  MeshBuilder builder;
  std::vector<std::vector<int>> rings(static_cast<std::size_t>(rows + 1));
  for (int k = 0; k <= rows; ++k) {
    for (const auto& [a, b] : border) {
      const auto xy = square_to_disk(a, b, m);
      rings[static_cast<std::size_t>(k)].push_back(builder.add_point({kRadius * xy.x(), kRadius * xy.y(), kHeight * k / rows}));
    }
  }
  for (int k = 0; k < rows; ++k) {
    const auto& lower = rings[static_cast<std::size_t>(k)];
    const auto& upper = rings[static_cast<std::size_t>(k + 1)];
    for (int t = 0; t < around; ++t) {
      const auto t0 = static_cast<std::size_t>(t), t1 = static_cast<std::size_t>((t + 1) % around);
      builder.add_quad(lower[t0], lower[t1], upper[t1], upper[t0]);
    }
  }
  for (const bool top : {false, true}) {
    const auto& ring = rings[top ? static_cast<std::size_t>(rows) : 0];
    std::vector<int> lattice(static_cast<std::size_t>((m + 1) * (m + 1)), -1);
    auto at = [&](int a, int b) -> int& { return lattice[static_cast<std::size_t>(a * (m + 1) + b)]; };
    for (std::size_t t = 0; t < border.size(); ++t) at(border[t][0], border[t][1]) = ring[t];
    for (int a = 1; a < m; ++a) {
      for (int b = 1; b < m; ++b) {
        const auto xy = square_to_disk(a, b, m);
        at(a, b) = builder.add_point({kRadius * xy.x(), kRadius * xy.y(), top ? kHeight : 0.0});
      }
    }
    for (int a = 0; a < m; ++a) {
      for (int b = 0; b < m; ++b) {
        if (top) builder.add_quad(at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b + 1));
        else builder.add_quad(at(a, b), at(a, b + 1), at(a + 1, b + 1), at(a + 1, b));
      }
    }
  }
  Shape shape{builder.build(), {}, {}};
  shape.demo_constraints.fixed = vertices_where(shape.mesh, [](const Vector3d& p) { return p.z() <= 0.08 * kHeight + 1e-12; });
  shape.demo_constraints.handles = {vertices_where(shape.mesh, [](const Vector3d& p) { return p.z() >= 0.92 * kHeight - 1e-12; })};
  shape.demo_transform = rotation_about(Vector3d::UnitX(), Vector3d(0, 0, 0.92 * kHeight), 60.0, Vector3d(0, -0.3, -0.25));
  return shape;
}

// ---- Cactus: a trunk (cylinder with domes) and two arms grown out of rectangular holes in its
// side, each a tube along an L-shaped path (out, a quarter bend, up) closed by a dome. Built from
// rings so that it is a closed manifold by construction.

struct ArmSpec {
  double side;         // −1: left arm, towards −y; +1: right arm, towards +y
  double height;       // where it leaves the trunk
  double radius;
  double reach;        // straight part outwards
  double bend_radius;  // quarter bend up
  double rise;         // straight part upwards
};

struct ArmPath {
  Vector3d start, out, up, bend_center;
  double reach, bend_radius, rise;
  double length() const { return reach + 0.5 * kPi * bend_radius + rise; }
  Vector3d center(double u) const {
    if (u <= reach) return start + u * out;
    const double bend_length = 0.5 * kPi * bend_radius;
    if (u <= reach + bend_length) {
      const double beta = (u - reach) / bend_radius;
      return bend_center - bend_radius * std::cos(beta) * up + bend_radius * std::sin(beta) * out;
    }
    return bend_center + bend_radius * out + (u - reach - bend_length) * up;
  }
  Vector3d tangent(double u) const {
    if (u <= reach) return out;
    const double beta = std::min(0.5 * kPi, (u - reach) / bend_radius);
    return std::cos(beta) * out + std::sin(beta) * up;
  }
};

struct Cactus {
  MeshBuilder builder;
  Vector3d left_tip;
  Vector3d left_elbow;
  Vector3d left_axis;
};

Cactus build_cactus(int resolution) {
  constexpr double kRadius = 0.1;
  constexpr double kBottom = 0.0;
  constexpr double kTop = 0.8;
  constexpr ArmSpec kArms[2] = {{-1.0, 0.30, 0.055, 0.07, 0.08, 0.16}, {1.0, 0.46, 0.048, 0.05, 0.07, 0.11}};
  const int around = std::max(12, resolution);
  const double spacing = 2.0 * kPi * kRadius / around;
  const int rows = std::max(8, static_cast<int>(std::lround((kTop - kBottom) / spacing)));
  auto angle = [&](int i) { return 2.0 * kPi * i / around; };
  auto row_height = [&](int j) { return kBottom + (kTop - kBottom) * j / rows; };

  Cactus cactus;
  auto& builder = cactus.builder;
  std::vector<int> grid(static_cast<std::size_t>((rows + 1) * around));
  auto at = [&](int j, int i) -> int& { return grid[static_cast<std::size_t>(j * around + ((i % around) + around) % around)]; };
  for (int j = 0; j <= rows; ++j) {
    for (int i = 0; i < around; ++i) {
      at(j, i) = builder.add_point({kRadius * std::cos(angle(i)), kRadius * std::sin(angle(i)), row_height(j)});
    }
  }

  // Domes: rings of `around` vertices closing on a pole; the bottom one flattened.
  const int dome_rings = std::max(2, static_cast<int>(std::lround(0.5 * kPi * kRadius / spacing)));
  for (const bool top : {true, false}) {
    const double sign = top ? 1.0 : -1.0;
    const double flatten = top ? 1.0 : 0.35;
    const double base = top ? kTop : kBottom;
    std::vector<int> previous(static_cast<std::size_t>(around));
    for (int i = 0; i < around; ++i) previous[static_cast<std::size_t>(i)] = at(top ? rows : 0, i);
    for (int k = 1; k <= dome_rings; ++k) {
      const double theta = 0.5 * kPi * k / dome_rings;
      std::vector<int> ring(static_cast<std::size_t>(around));
      if (k == dome_rings) {
        std::fill(ring.begin(), ring.end(), builder.add_point({0.0, 0.0, base + sign * flatten * kRadius}));
      } else {
        for (int i = 0; i < around; ++i) {
          ring[static_cast<std::size_t>(i)] = builder.add_point({kRadius * std::cos(theta) * std::cos(angle(i)),
                                                                 kRadius * std::cos(theta) * std::sin(angle(i)),
                                                                 base + sign * flatten * kRadius * std::sin(theta)});
        }
      }
      for (int i = 0; i < around; ++i) {
        const auto i0 = static_cast<std::size_t>(i), i1 = static_cast<std::size_t>((i + 1) % around);
        const auto& lower = top ? previous : ring;
        const auto& upper = top ? ring : previous;
        if (lower[i0] == lower[i1]) builder.add_triangle(lower[i0], upper[i1], upper[i0]);
        else if (upper[i0] == upper[i1]) builder.add_triangle(lower[i0], lower[i1], upper[i0]);
        else builder.add_quad(lower[i0], lower[i1], upper[i1], upper[i0]);
      }
      previous = ring;
    }
  }

  // Arms: a rectangle of side quads is left out and its border becomes the arm's first ring.
  std::vector<bool> removed(static_cast<std::size_t>(rows * around), false);
  std::vector<int> crease;  // vertices rounded afterwards
  for (const ArmSpec& arm : kArms) {
    const double facing = arm.side < 0 ? -0.5 * kPi : 0.5 * kPi;
    const int width = std::max(2, static_cast<int>(std::lround(2.0 * arm.radius / spacing)));
    const int first_column = static_cast<int>(std::lround(facing / (2.0 * kPi) * around)) - width / 2;
    const int first_row = static_cast<int>(std::lround((arm.height - kBottom) / (kTop - kBottom) * rows)) - width / 2;
    for (int j = first_row; j < first_row + width; ++j) {
      for (int i = first_column; i < first_column + width; ++i) {
        removed[static_cast<std::size_t>(j * around + ((i % around) + around) % around)] = true;
      }
    }
    const Vector3d out(0.0, arm.side, 0.0);
    const Vector3d up = Vector3d::UnitZ();
    const Vector3d side_axis = out.cross(up);  // perpendicular to the plane of the bend
    const double middle_column = first_column + 0.5 * width;
    const Vector3d hole_center(kRadius * std::cos(2.0 * kPi * middle_column / around), kRadius * std::sin(2.0 * kPi * middle_column / around),
                               0.5 * (row_height(first_row) + row_height(first_row + width)));

    // Border of the hole, ordered by angle about its center in the (side_axis, up) plane.
    std::vector<std::pair<double, int>> border;
    for (int j = first_row; j <= first_row + width; ++j) {
      for (int i = first_column; i <= first_column + width; ++i) {
        const bool on_border = j == first_row || j == first_row + width || i == first_column || i == first_column + width;
        if (!on_border) continue;
        const Vector3d offset = builder.point(at(j, i)) - hole_center;
        border.emplace_back(std::atan2(offset.dot(up), offset.dot(side_axis)), at(j, i));
      }
    }
    std::sort(border.begin(), border.end());
    std::vector<double> ring_angle;
    std::vector<int> previous;
    for (const auto& [alpha, vertex] : border) {
      ring_angle.push_back(alpha);
      previous.push_back(vertex);
      crease.push_back(vertex);
    }
    for (int j = first_row - 2; j <= first_row + width + 2; ++j) {
      for (int i = first_column - 2; i <= first_column + width + 2; ++i) {
        const bool inside = j >= first_row && j <= first_row + width && i >= first_column && i <= first_column + width;
        if (!inside && j >= 0 && j <= rows) crease.push_back(at(j, i));
      }
    }

    const ArmPath path{hole_center, out, up, hole_center + arm.reach * out + arm.bend_radius * up, arm.reach, arm.bend_radius, arm.rise};
    const auto ring_size = previous.size();
    auto add_ring_strip = [&](const std::vector<int>& lower, const std::vector<int>& upper) {
      for (std::size_t m = 0; m < ring_size; ++m) {
        const std::size_t next = (m + 1) % ring_size;
        if (upper[m] == upper[next]) builder.add_triangle(lower[m], upper[m], lower[next]);
        else builder.add_quad(lower[m], upper[m], upper[next], lower[next]);
      }
    };
    const int steps = std::max(3, static_cast<int>(std::lround(path.length() / spacing)));
    for (int k = 1; k <= steps; ++k) {
      const double u = path.length() * k / steps;
      const Vector3d normal = side_axis.cross(path.tangent(u));
      std::vector<int> ring(ring_size);
      for (std::size_t m = 0; m < ring_size; ++m) {
        ring[m] = builder.add_point(path.center(u) +
                                    arm.radius * (std::cos(ring_angle[m]) * side_axis + std::sin(ring_angle[m]) * normal));
        if (k <= 2) crease.push_back(ring[m]);
      }
      add_ring_strip(previous, ring);
      previous = std::move(ring);
    }
    const Vector3d end = path.center(path.length());
    const Vector3d end_normal = side_axis.cross(up);
    const int cap_rings = std::max(2, static_cast<int>(std::lround(0.5 * kPi * arm.radius / spacing)));
    for (int k = 1; k <= cap_rings; ++k) {
      const double theta = 0.5 * kPi * k / cap_rings;
      std::vector<int> ring(ring_size);
      if (k == cap_rings) {
        std::fill(ring.begin(), ring.end(), builder.add_point(end + arm.radius * up));
      } else {
        for (std::size_t m = 0; m < ring_size; ++m) {
          ring[m] = builder.add_point(end + arm.radius * std::sin(theta) * up +
                                      arm.radius * std::cos(theta) *
                                          (std::cos(ring_angle[m]) * side_axis + std::sin(ring_angle[m]) * end_normal));
        }
      }
      add_ring_strip(previous, ring);
      previous = std::move(ring);
    }
    if (arm.side < 0) {
      cactus.left_tip = end + arm.radius * up;
      cactus.left_elbow = path.bend_center;
      cactus.left_axis = side_axis;
    }
  }

  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < around; ++i) {
      if (removed[static_cast<std::size_t>(j * around + i)]) continue;
      builder.add_quad(at(j, i), at(j, i + 1), at(j + 1, i + 1), at(j + 1, i));
    }
  }
  std::sort(crease.begin(), crease.end());
  crease.erase(std::unique(crease.begin(), crease.end()), crease.end());
  builder.smooth(crease, 12, 0.5);
  return cactus;
}

Shape make_cactus(int resolution) {
  Cactus cactus = build_cactus(resolution);
  Shape shape{cactus.builder.build(), {}, {}};
  const Vector3d tip = cactus.left_tip;
  shape.demo_constraints.handles = {vertices_where(shape.mesh, [&](const Vector3d& p) { return (p - tip).norm() <= 0.075; })};
  shape.demo_constraints.fixed = vertices_where(shape.mesh, [](const Vector3d& p) { return p.z() <= 0.2; });
  // Bend the left arm outwards about its elbow (the paper's Figure 1).
  shape.demo_transform = rotation_about(cactus.left_axis, cactus.left_elbow, -70.0);
  return shape;
}

}  // namespace

std::optional<ShapeKind> parse_shape(std::string_view name) {
  for (auto shape : {ShapeKind::Cactus, ShapeKind::Bar, ShapeKind::Cylinder, ShapeKind::Sphere}) {
    if (name == to_string(shape)) return shape;
  }
  return std::nullopt;
}

std::string_view to_string(ShapeKind shape) {
  switch (shape) {
    case ShapeKind::Cactus: return "cactus";
    case ShapeKind::Bar: return "bar";
    case ShapeKind::Cylinder: return "cylinder";
    case ShapeKind::Sphere: return "sphere";
  }
  return "?";
}

Shape make_shape(ShapeKind shape, int resolution) {
  if (resolution < 8) throw InputError("shape resolution " + std::to_string(resolution) + " is below the minimum of 8");
  if (resolution > 4096) throw InputError("shape resolution " + std::to_string(resolution) + " is above the maximum of 4096");
  switch (shape) {
    case ShapeKind::Cactus: return make_cactus(resolution);
    case ShapeKind::Bar: return make_bar(resolution);
    case ShapeKind::Cylinder: return make_cylinder(resolution);
    case ShapeKind::Sphere: return make_sphere(resolution);
  }
  throw InputError("unknown shape");
}

}  // namespace hdeform

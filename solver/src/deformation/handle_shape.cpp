#include "hdeform/handle_shape.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace hdeform {
namespace {

// Normals turning through less than this are a patch (its field is fine), more is a ring.
constexpr double kMinimumDegrees = 90.0;
constexpr double kMaximumDegrees = 300.0;
// Near one plane: the smallest spread of the normals well below the middle one; and turning
// at all: the middle spread is that of normals covering about 65 degrees or more.
constexpr double kPlanarRatio = 0.4;
constexpr double kMinimumTurnSpread = 0.1;
// Normals closer than this to the plane's normal (a cap on the ring) have no direction in it.
constexpr double kMinimumInPlane = 0.5;

// Area-weighted normals of the handle's vertices, unit length (zero where the area is zero).
std::vector<Eigen::Vector3d> handle_normals(const Mesh& mesh, std::span<const int> handle) {
  std::vector<int> slot(static_cast<std::size_t>(mesh.vertex_count()), -1);
  for (std::size_t i = 0; i < handle.size(); ++i) slot[static_cast<std::size_t>(handle[i])] = static_cast<int>(i);
  std::vector<Eigen::Vector3d> normals(handle.size(), Eigen::Vector3d::Zero());
  for (Eigen::Index t = 0; t < mesh.triangle_count(); ++t) {
    const Eigen::Vector3d a = mesh.positions.row(mesh.triangles(t, 0));
    const Eigen::Vector3d b = mesh.positions.row(mesh.triangles(t, 1));
    const Eigen::Vector3d c = mesh.positions.row(mesh.triangles(t, 2));
    const Eigen::Vector3d area_normal = (b - a).cross(c - a);
    for (int corner = 0; corner < 3; ++corner) {
      const int s = slot[static_cast<std::size_t>(mesh.triangles(t, corner))];
      if (s >= 0) normals[static_cast<std::size_t>(s)] += area_normal;
    }
  }
  for (auto& normal : normals) {
    const double length = normal.norm();
    if (length > 0.0) normal /= length;
  }
  return normals;
}

// 360 minus the largest gap between the directions, degrees.
double turned_degrees(std::vector<double> angles) {
  if (angles.size() < 2) return 0.0;
  std::sort(angles.begin(), angles.end());
  double largest_gap = angles.front() + 2.0 * std::numbers::pi - angles.back();
  for (std::size_t i = 1; i < angles.size(); ++i) largest_gap = std::max(largest_gap, angles[i] - angles[i - 1]);
  return 360.0 - largest_gap * 180.0 / std::numbers::pi;
}

}  // namespace

std::optional<double> partial_ring_degrees(const Mesh& mesh, std::span<const int> handle) {
  if (handle.size() < 3) return std::nullopt;
  const auto normals = handle_normals(mesh, handle);
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  for (const auto& normal : normals) spread += normal * normal.transpose();
  spread /= static_cast<double>(normals.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> principal(spread);
  const Eigen::Vector3d spreads = principal.eigenvalues();  // increasing
  if (spreads(1) < kMinimumTurnSpread || spreads(0) > kPlanarRatio * spreads(1)) return std::nullopt;

  const Eigen::Vector3d u = principal.eigenvectors().col(2);
  const Eigen::Vector3d v = principal.eigenvectors().col(1);
  std::vector<double> angles;
  angles.reserve(normals.size());
  for (const auto& normal : normals) {
    const double x = normal.dot(u);
    const double y = normal.dot(v);
    if (std::hypot(x, y) >= kMinimumInPlane) angles.push_back(std::atan2(y, x));
  }
  const double degrees = turned_degrees(std::move(angles));
  if (degrees < kMinimumDegrees || degrees > kMaximumDegrees) return std::nullopt;
  return degrees;
}

std::vector<std::string> handle_shape_warnings(const Mesh& mesh, const EditConstraints& constraints) {
  std::vector<std::string> lines;
  for (std::size_t h = 0; h < constraints.handles.size(); ++h) {
    const auto degrees = partial_ring_degrees(mesh, constraints.handles[h]);
    if (!degrees) continue;
    const std::string name = constraints.handles.size() == 1 ? "the handle" : "handle " + std::to_string(h + 1);
    lines.push_back(name + " wraps only about " + std::to_string(static_cast<int>(std::lround(*degrees))) +
                    " degrees of the way round the shape: its field is lopsided, so a bend or twist leans the "
                    "section under it; paint the whole ring, front and back");
  }
  return lines;
}

}  // namespace hdeform

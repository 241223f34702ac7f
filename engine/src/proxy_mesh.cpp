#include "hdeform/engine/proxy_mesh.h"

#include <meshoptimizer.h>

#include <vector>

#include "hdeform/mesh.h"

namespace hdeform::engine {

namespace {
constexpr float kProxyError = 0.02f;  // relative to the mesh's extent
}

Eigen::MatrixXi proxy_triangles(const Eigen::MatrixXi& triangles, const Eigen::MatrixXd& positions, Eigen::Index target) {
  validate_triangles(triangles, positions.rows(), "mesh to simplify");
  if (target <= 0 || triangles.rows() <= 2 * target) return {};
  const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> points = positions.cast<float>();
  const Eigen::Matrix<unsigned, Eigen::Dynamic, 3, Eigen::RowMajor> indices = triangles.cast<unsigned>();
  std::vector<unsigned> simplified(static_cast<std::size_t>(indices.size()));
  const std::size_t count = meshopt_simplify(simplified.data(), indices.data(), static_cast<std::size_t>(indices.size()), points.data(),
                                             static_cast<std::size_t>(points.rows()), sizeof(float) * 3, static_cast<std::size_t>(3 * target),
                                             kProxyError, 0, nullptr);
  // Drawing order matters to a rasterizer's vertex cache as much as the count does.
  meshopt_optimizeVertexCache(simplified.data(), simplified.data(), count, static_cast<std::size_t>(points.rows()));
  Eigen::MatrixXi proxy(static_cast<Eigen::Index>(count / 3), 3);
  for (Eigen::Index t = 0; t < proxy.rows(); ++t) {
    for (int c = 0; c < 3; ++c) proxy(t, c) = static_cast<int>(simplified[static_cast<std::size_t>(3 * t + c)]);
  }
  return proxy;
}

}  // namespace hdeform::engine

#include "hdeform/engine/geometry_exchange.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <algorithm>

#include "hdeform/mesh.h"
#include "hdeform/trace.h"

namespace hdeform::engine {
namespace {
// How far ahead, in incidences (about 16 vertices), write_vertex asks for the face normals it will
// sum. On a scan they lie far apart in memory, and without the prefetch the vertex pass waited on
// them: at 3.3M triangles 27–35 ms of a 37–47 ms whole write, 15 ms with it (2 threads).
constexpr std::size_t kIncidencesAhead = 96;
}  // namespace

GeometryExchange::GeometryExchange(std::size_t vertex_count) : vertex_count_(vertex_count) {
  for (auto& slot : slots_) slot.position_normal.assign(6 * vertex_count, 0.0f);
}

void GeometryExchange::publish() {
  slots_[back_].version = ++published_;
  back_ = ready_.exchange(back_ | kFresh, std::memory_order_acq_rel) & ~kFresh;
}

const GeometrySnapshot* GeometryExchange::acquire() {
  if (ready_.load(std::memory_order_acquire) & kFresh) {
    front_ = ready_.exchange(front_, std::memory_order_acq_rel) & ~kFresh;
    has_front_ = true;
  }
  return has_front_ ? &slots_[front_] : nullptr;
}

VertexNormals::VertexNormals(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count)
    : VertexNormals(std::make_shared<const Eigen::MatrixXi>(triangles), vertex_count) {}

VertexNormals::VertexNormals(std::shared_ptr<const Eigen::MatrixXi> shared_triangles, Eigen::Index vertex_count)
    : triangles_(std::move(shared_triangles)), triangle_start_(static_cast<std::size_t>(vertex_count) + 1, 0),
      face_normals_(static_cast<std::size_t>(triangles_->rows())) {
  const Eigen::MatrixXi& triangles = *triangles_;
  validate_triangles(triangles, vertex_count, "mesh to draw");
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    for (int k = 0; k < 3; ++k) ++triangle_start_[static_cast<std::size_t>(triangles(t, k)) + 1];
  }
  for (std::size_t v = 0; v + 1 < triangle_start_.size(); ++v) triangle_start_[v + 1] += triangle_start_[v];
  // Past the end, the prefetch's look-ahead (triangle 0: any valid one).
  incident_.assign(static_cast<std::size_t>(triangle_start_.back()) + kIncidencesAhead, 0);
  std::vector<int> fill(triangle_start_.begin(), triangle_start_.end() - 1);
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    for (int k = 0; k < 3; ++k) incident_[static_cast<std::size_t>(fill[static_cast<std::size_t>(triangles(t, k))]++)] = static_cast<int>(t);
  }
}

void VertexNormals::write_vertex(const Eigen::MatrixXd& positions, Eigen::Index v, float* out) const {
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (int k = triangle_start_[static_cast<std::size_t>(v)]; k < triangle_start_[static_cast<std::size_t>(v) + 1]; ++k) {
    const auto incidence = static_cast<std::size_t>(k);
    __builtin_prefetch(face_normals_.data() + incident_[incidence + kIncidencesAhead]);
    normal += face_normals_[static_cast<std::size_t>(incident_[incidence])];
  }
  const double length = normal.norm();
  if (length > 0.0) normal /= length;
  float* vertex = out + 6 * v;
  for (int c = 0; c < 3; ++c) {
    vertex[c] = static_cast<float>(positions(v, c));
    vertex[3 + c] = static_cast<float>(normal(c));
  }
}

namespace {
Eigen::Vector3d face_normal(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles, Eigen::Index t) {
  const Eigen::Vector3d a = positions.row(triangles(t, 0)), b = positions.row(triangles(t, 1)), c = positions.row(triangles(t, 2));
  return (b - a).cross(c - a);  // length: twice the area
}
}  // namespace

void VertexNormals::write(const Eigen::MatrixXd& positions, GeometrySnapshot& snapshot) {
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, triangles_->rows(), 4096), [&](const auto& range) {
    for (Eigen::Index t = range.begin(); t != range.end(); ++t) face_normals_[static_cast<std::size_t>(t)] = face_normal(positions, *triangles_, t);
  });
  float* out = snapshot.position_normal.data();
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, positions.rows(), 4096), [&](const auto& range) {
    for (Eigen::Index v = range.begin(); v != range.end(); ++v) write_vertex(positions, v, out);
  });
  snapshot.only_vertices.reset();
  snapshot.every_position = true;
}

VertexNormals::Subset VertexNormals::subset(const Eigen::MatrixXi& triangles) const {
  auto vertices = std::make_shared<std::vector<int>>(triangles.data(), triangles.data() + triangles.size());
  std::sort(vertices->begin(), vertices->end());
  vertices->erase(std::unique(vertices->begin(), vertices->end()), vertices->end());
  Subset subset;
  for (const int v : *vertices) {
    for (int k = triangle_start_[static_cast<std::size_t>(v)]; k < triangle_start_[static_cast<std::size_t>(v) + 1]; ++k) {
      subset.triangles.push_back(incident_[static_cast<std::size_t>(k)]);
    }
  }
  std::sort(subset.triangles.begin(), subset.triangles.end());
  subset.triangles.erase(std::unique(subset.triangles.begin(), subset.triangles.end()), subset.triangles.end());
  subset.vertices = std::move(vertices);
  return subset;
}

void VertexNormals::write(const Eigen::MatrixXd& positions, const Subset& subset, GeometrySnapshot& snapshot) {
  const auto& triangles = subset.triangles;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      face_normals_[static_cast<std::size_t>(triangles[i])] = face_normal(positions, *triangles_, triangles[i]);
    }
  });
  const auto& vertices = *subset.vertices;
  float* out = snapshot.position_normal.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertices.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) write_vertex(positions, vertices[i], out);
  });
  snapshot.only_vertices = subset.vertices;
  snapshot.every_position = false;
}

void VertexNormals::write_positions(const Eigen::MatrixXd& positions, const Subset& normals_of, GeometrySnapshot& snapshot) {
  float* out = snapshot.position_normal.data();
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, positions.rows(), 8192), [&](const auto& range) {
    for (Eigen::Index v = range.begin(); v != range.end(); ++v) {
      for (int c = 0; c < 3; ++c) out[6 * v + c] = static_cast<float>(positions(v, c));
    }
  });
  write(positions, normals_of, snapshot);
  snapshot.every_position = true;
}

GeometryPublisher::GeometryPublisher(GeometryExchange& exchange, const Eigen::MatrixXi& triangles)
    : exchange_(exchange), normals_(triangles, static_cast<Eigen::Index>(exchange.vertex_count())) {}

GeometryPublisher::GeometryPublisher(GeometryExchange& exchange, std::shared_ptr<const Eigen::MatrixXi> triangles)
    : exchange_(exchange), normals_(std::move(triangles), static_cast<Eigen::Index>(exchange.vertex_count())) {}

void GeometryPublisher::set_proxy(const Eigen::MatrixXi& proxy_triangles) {
  validate_triangles(proxy_triangles, static_cast<Eigen::Index>(exchange_.vertex_count()), "proxy to publish");
  auto proxy = proxy_triangles.rows() > 0 ? std::make_shared<const VertexNormals::Subset>(normals_.subset(proxy_triangles)) : nullptr;
  const std::lock_guard lock(mutex_);
  proxy_ = std::move(proxy);
}

std::shared_ptr<const std::vector<int>> GeometryPublisher::proxy_vertices() const {
  const std::lock_guard lock(mutex_);
  return proxy_ ? proxy_->vertices : nullptr;
}

void GeometryPublisher::publish(const Eigen::MatrixXd& positions, std::uint64_t tag, Detail detail) {
  const std::lock_guard lock(mutex_);
  GeometrySnapshot& back = exchange_.back();
  if (detail == Detail::Proxy && proxy_) {
    const trace::Scope traced("positions and normals, the proxy's vertices", "publish");
    normals_.write(positions, *proxy_, back);
  } else if (detail == Detail::ProxyNormals && proxy_) {
    const trace::Scope traced("positions of every vertex, the proxy's normals", "publish");
    normals_.write_positions(positions, *proxy_, back);
  } else {
    const trace::Scope traced("positions and normals, every vertex", "publish");
    normals_.write(positions, back);
  }
  back.tag = tag;
  exchange_.publish();
}

}  // namespace hdeform::engine

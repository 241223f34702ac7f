#pragma once
/// @file
/// The handoff of vertex geometry from the solver to the renderer. The solver fills the back
/// buffer and publishes it with one atomic exchange; the renderer takes the newest published
/// buffer at the start of a frame without ever waiting. A third slot is the one the renderer is
/// reading, so neither side blocks the other.
#include <Eigen/Core>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace hdeform::engine {

/// Positions and normals as the GPU reads them: 6 floats per vertex, interleaved.
struct GeometrySnapshot {
  std::vector<float> position_normal;
  std::uint64_t version = 0;  ///< increases with every publication
  std::uint64_t tag = 0;      ///< the publisher's label (the editor: the request it answers)
  /// Set when this publication wrote these vertices' normals only (a proxy's, ascending), and
  /// unless every_position their positions only too: the others hold an older one's, so the
  /// snapshot is drawn only as the proxy. Null: every vertex.
  std::shared_ptr<const std::vector<int>> only_vertices;
  /// With only_vertices set, whether every vertex's position was written all the same (a settling
  /// shape): then the snapshot is the whole shape for picking and painting, though drawn as the
  /// proxy. False: the other vertices' positions are an older publication's too.
  bool every_position = true;
};

/// Hands positions and normals from one writer thread (the solver) to one reader thread (the
/// renderer) through three buffers: the writer never waits, the reader takes the newest.
class GeometryExchange {
 public:
  /// Three buffers for `vertex_count` vertices.
  explicit GeometryExchange(std::size_t vertex_count);

  /// The number of vertices each snapshot holds.
  std::size_t vertex_count() const { return vertex_count_; }

  /// Writer (one thread): fill back(), then publish() it.
  GeometrySnapshot& back() { return slots_[back_]; }
  /// Makes back() the newest snapshot (one atomic exchange) and gives the writer another buffer.
  void publish();

  /// Reader (one thread): the newest published snapshot (the same as last time if nothing new
  /// came), or nullptr before the first publication. Never blocks.
  const GeometrySnapshot* acquire();

 private:
  static constexpr std::uint32_t kFresh = 4;
  std::size_t vertex_count_;
  std::array<GeometrySnapshot, 3> slots_;
  std::atomic<std::uint32_t> ready_{1};  ///< slot index, | kFresh when not yet taken
  std::uint32_t back_ = 0;
  std::uint32_t front_ = 2;
  bool has_front_ = false;
  std::uint64_t published_ = 0;
};

/// Area-weighted vertex normals, recomputed in parallel from positions; each vertex sums its
/// triangles in a fixed order.
class VertexNormals {
 public:
  /// Precomputes each vertex's incident triangles; the triangles are copied.
  VertexNormals(const Eigen::MatrixXi& triangles, Eigen::Index vertex_count);
  /// The same, sharing the triangles (not copied).
  VertexNormals(std::shared_ptr<const Eigen::MatrixXi> triangles, Eigen::Index vertex_count);
  /// Writes positions (as floats) and unit normals into `snapshot`. Allocation-free.
  void write(const Eigen::MatrixXd& positions, GeometrySnapshot& snapshot);

  /// Some vertices and the triangles around them: what write() of those vertices alone reads.
  struct Subset {
    std::shared_ptr<const std::vector<int>> vertices;  ///< ascending, distinct
    std::vector<int> triangles;                         ///< every triangle at one of them, ascending
  };
  /// The subset of the vertices that `triangles` (a proxy's) use.
  Subset subset(const Eigen::MatrixXi& triangles) const;
  /// Writes the subset's vertices alone, each with the very bits write() gives it, and marks the
  /// snapshot as holding them only. Allocation-free.
  void write(const Eigen::MatrixXd& positions, const Subset& subset, GeometrySnapshot& snapshot);
  /// Writes every vertex's position and the subset's normals, each with the very bits write()
  /// gives it: a snapshot drawn as the proxy but holding the whole shape (every_position).
  /// Allocation-free.
  void write_positions(const Eigen::MatrixXd& positions, const Subset& normals_of, GeometrySnapshot& snapshot);

 private:
  void write_vertex(const Eigen::MatrixXd& positions, Eigen::Index v, float* out) const;

  std::shared_ptr<const Eigen::MatrixXi> triangles_;
  std::vector<int> triangle_start_;  ///< per vertex: its incident triangles
  std::vector<int> incident_;
  std::vector<Eigen::Vector3d> face_normals_;
};

/// What the solver thread calls after each update: positions → back buffer with normals → publish.
/// Publications may come from several threads (the solver's, and the window's for the rest shape);
/// they are taken one at a time, and set_proxy() may come from any thread.
class GeometryPublisher {
 public:
  /// Writes into `exchange` the geometry of a mesh with these triangles.
  GeometryPublisher(GeometryExchange& exchange, const Eigen::MatrixXi& triangles);
  /// The same, sharing the triangles (not copied: at 13 million triangles a copy is 158 MB).
  GeometryPublisher(GeometryExchange& exchange, std::shared_ptr<const Eigen::MatrixXi> triangles);

  /// Every vertex, or only the proxy's (set_proxy) for frames that will draw the proxy anyway: a
  /// drag on a large mesh then publishes a few thousand vertices instead of millions. ProxyNormals:
  /// every vertex's position but only the proxy's normals, for a shape that the frames draw as the
  /// proxy (it is replaced within moments) but that may be picked on: a settling one, whose
  /// normals at 3.3 million triangles would take most of its publication.
  enum class Detail { Whole, Proxy, ProxyNormals };
  /// The proxy's triangles (proxy_mesh.h); empty: none, and Proxy publishes the whole mesh.
  void set_proxy(const Eigen::MatrixXi& proxy_triangles);
  /// The vertices a Proxy publication writes (ascending, distinct); null without a proxy.
  std::shared_ptr<const std::vector<int>> proxy_vertices() const;
  /// Fills the back buffer with `positions` and their normals, labels it `tag`, and publishes it.
  /// Without a proxy every detail is Whole.
  void publish(const Eigen::MatrixXd& positions, std::uint64_t tag = 0, Detail detail = Detail::Whole);

 private:
  GeometryExchange& exchange_;
  mutable std::mutex mutex_;  // one publication at a time; guards proxy_ too
  VertexNormals normals_;
  std::shared_ptr<const VertexNormals::Subset> proxy_;
};

}  // namespace hdeform::engine

#pragma once
/// @file
/// A mesh's buffers on the device, made before a MeshRenderer takes them: the triangles' indices
/// and each frame's geometry and per-vertex attributes. On a CPU device what they cost is their
/// first writes (new pages: at 13 million triangles they held the editor's window for 1.5 s), so
/// writing is apart from making: make them on the thread that calls Vulkan, fill() them on any
/// thread (it calls no Vulkan), and MeshRenderer::set_mesh takes them.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/engine/vulkan_context.h"

namespace hdeform::engine {

/// The index buffer and each frame's geometry and attribute buffers of one mesh, host-visible
/// and mapped, until a MeshRenderer takes them.
class MeshBuffers {
 public:
  /// Unwritten buffers for a mesh of `vertex_count` vertices and `triangle_count` triangles, drawn
  /// with `frames` frames in flight (MeshRenderer::frame_count()). Throws RenderError when the
  /// device has no memory for them.
  MeshBuffers(const VulkanContext& context, std::size_t vertex_count, std::size_t triangle_count, uint32_t frames);
  /// Destroys the buffers no renderer took (on the thread that calls Vulkan).
  ~MeshBuffers();
  MeshBuffers(const MeshBuffers&) = delete;
  MeshBuffers& operator=(const MeshBuffers&) = delete;

  /// Told the share of fill() done so far, between its pieces; returning false stops it.
  using Progress = std::function<bool(double done)>;
  /// Writes every buffer: the indices of `triangles` (InputError naming the first triangle with
  /// a vertex out of range, or a count other than the one made for), each frame's
  /// geometry from `snapshot` when it holds every vertex (otherwise zeros, and the renderer uploads
  /// the geometry at its first frame), and attributes of no field and no class. Any thread, one call at a time.
  /// Returns false, the buffers unfilled, when `progress` stopped it.
  bool fill(const Eigen::MatrixXi& triangles, const GeometrySnapshot* snapshot, const Progress& progress = {});
  /// Whether fill() has written everything.
  bool filled() const { return filled_; }
  /// The vertices they were made for.
  std::size_t vertex_count() const { return vertex_count_; }
  /// The triangles they were made for.
  std::size_t triangle_count() const { return triangle_count_; }
  /// The frames in flight they were made for.
  uint32_t frames() const { return static_cast<uint32_t>(frames_.size()); }

 private:
  friend class MeshRenderer;
  void release();
  struct Frame {
    Buffer geometry;
    std::uint64_t geometry_version = 0;  ///< the snapshot written into it (0: none)
    Buffer attributes;
  };
  const VulkanContext& context_;
  std::size_t vertex_count_;
  std::size_t triangle_count_;
  Buffer indices_;
  std::vector<Frame> frames_;
  std::vector<float> attributes_;  ///< the renderer's own copy of the attributes (field, class per vertex)
  bool filled_ = false;
};

}  // namespace hdeform::engine

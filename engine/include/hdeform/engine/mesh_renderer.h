#pragma once
/// @file
/// Draws one mesh: smooth or flat shading, the scalar field as a colormap with isolines and a
/// colour bar, vertex classes, back faces tinted, an optional wireframe overlay, markers, and a
/// ground grid over a neutral background (the clear colour: a full-screen gradient cost a CPU
/// rasterizer 12% of its frame). The same object draws into any target created with a
/// compatible render pass (render_targets.h).
#include <Eigen/Core>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "hdeform/engine/camera.h"
#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/engine/mesh_buffers.h"
#include "hdeform/engine/render_targets.h"
#include "hdeform/engine/vulkan_context.h"
#include "render_config.h"

namespace hdeform::engine {

/// What a frame shows and how.
struct RenderSettings {
  bool show_field = true;    ///< the field's colormap, when a field is set
  bool show_classes = true;  ///< fixed and handle vertices in their colours
  bool flat_shading = false;
  bool wireframe = false;
  bool lighting = true;      ///< off: plain colours (tests read colormap values directly)
  bool ground = true;
  bool legend = true;        ///< colour bar of the field's range, with a tick per isoline
  /// Back faces drawn (tinted): Auto draws them for open meshes only. On a closed mesh they are
  /// hidden unless it intersects itself, and skipping them halves a CPU rasterizer's work.
  enum class BackFaces { Auto, Show, Cull } back_faces = BackFaces::Auto;
  float field_min = 0.0f;    ///< the value at the colormap's start
  float field_max = 1.0f;    ///< ... and at its end
  float isoline_step = 0.1f; ///< 0: no isolines
  float isoline_width = 1.5f;  ///< pixels
  bool proxy = false;        ///< draw the proxy set by set_proxy (when there is one) instead of the mesh
};

/// Vertex classes as the shaders read them.
inline uint32_t fixed_class() { return HD_CLASS_FIXED; }
/// The class of a vertex outside the region of interest.
inline uint32_t outside_class() { return HD_CLASS_OUTSIDE; }
/// The class of handle `handle`'s vertices (each handle in its own colour).
inline uint32_t handle_class(std::size_t handle) { return HD_CLASS_HANDLE_FIRST + static_cast<uint32_t>(handle); }
/// A vertex drawn in its own colour (components in [0, 1]), shown with the classes.
inline uint32_t color_class(const Eigen::Vector3f& rgb) {
  const Eigen::Vector3f clamped = rgb.cwiseMax(0.0f).cwiseMin(1.0f) * 255.0f + Eigen::Vector3f::Constant(0.5f);
  return HD_CLASS_RGB | static_cast<uint32_t>(clamped.x()) | (static_cast<uint32_t>(clamped.y()) << 8) | (static_cast<uint32_t>(clamped.z()) << 16);
}

/// Part `index` of `count` of a picture drawn over several scene passes (SwapchainTarget's
/// slices): that share of the mesh's triangles, in their order; the ground, markers and legend
/// with the last part. Drawn one after another over the same colour and depth, the parts give the
/// picture drawn whole, pixel for pixel. The first `ramp` parts are 1/2^ramp, …, 1/4, 1/2 of the
/// others (a first picture's first slice also draws into memory the device has not used yet).
struct DrawSlice {
  int index = 0;
  int count = 1;
  int ramp = 0;  ///< 0 to 16
};

/// The share of a picture's draws in the parts before `slice.index`: 0 at the first part, 1 past
/// the last.
double share_before(const DrawSlice& slice);

/// A dot drawn at a position (transfer mode's marker pairs).
struct Marker {
  Eigen::Vector3f position;
  uint32_t color = 0;  ///< index into the handle colours
};

/// Draws one mesh with its field, classes and markers, the ground and the legend, into any target
/// that shares the render pass layout; its geometry comes from a GeometryExchange, never waited for.
class MeshRenderer {
 public:
  /// Pipelines and per-frame buffers for `frames_in_flight` frames into passes of `render_pass`'s layout.
  MeshRenderer(const VulkanContext& context, VkRenderPass render_pass, const PassFormat& format, uint32_t frames_in_flight);
  ~MeshRenderer();
  MeshRenderer(const MeshRenderer&) = delete;
  MeshRenderer& operator=(const MeshRenderer&) = delete;

  /// A new mesh (waits until the device is idle). Its geometry then comes from `geometry`, which
  /// must outlive this renderer or the next set_mesh, and is read on the thread that calls this
  /// and prepare(); `rest` places the ground and the camera.
  /// `closed`: every_edge_has_its_reverse(triangles), where the caller has worked it out already
  /// (off the frame loop: 0.3 s at 3.3 million triangles); else it is worked out here.
  void set_mesh(const Eigen::MatrixXi& triangles, GeometryExchange& geometry, const Bounds& rest, UpAxis up,
                std::optional<bool> closed = std::nullopt);
  /// The same with the mesh's buffers made and filled beforehand (mesh_buffers.h: the first
  /// writes off the frame loop), for this renderer's frame_count() and `geometry`'s vertex count.
  /// `closed` as above, worked out by the caller.
  void set_mesh(std::unique_ptr<MeshBuffers> buffers, GeometryExchange& geometry, const Bounds& rest, UpAxis up, bool closed);
  /// The frames in flight it was made for.
  uint32_t frame_count() const { return static_cast<uint32_t>(frames_.size()); }
  /// A coarser set of triangles over the same vertices (proxy_mesh.h), drawn when the settings ask
  /// for it; empty: none. Reset by set_mesh.
  void set_proxy(const Eigen::MatrixXi& triangles);
  /// Whether a proxy is set.
  bool has_proxy() const { return proxy_index_count_ > 0; }
  /// Whether every edge of the mesh set last has two triangles (no boundary).
  bool mesh_is_closed() const { return closed_; }
  /// Per-vertex field values (empty: none) and classes (empty: all free).
  void set_field(std::span<const float> values);
  /// Per-vertex classes (fixed_class(), handle_class(k), outside_class(), color_class()); empty: all free.
  void set_classes(std::span<const uint32_t> classes);
  /// Dots to draw over the mesh; empty: none.
  void set_markers(std::span<const Marker> markers);

  /// Before recording frame slot `frame` (whose previous submission the caller has waited for):
  /// takes the newest published geometry without waiting, uploads what changed, writes uniforms.
  void prepare(uint32_t frame, const Camera& camera, const RenderSettings& settings, VkExtent2D extent) {
    prepare(frame, camera, settings, VkRect2D{{0, 0}, extent});
  }
  /// Records the draws inside a begun render pass.
  void record(VkCommandBuffer commands, uint32_t frame, VkExtent2D extent, DrawSlice slice = {}) const {
    record(commands, frame, VkRect2D{{0, 0}, extent}, slice);
  }
  /// The same into a part of the target (several views side by side): the camera's aspect and
  /// every pixel size are the area's.
  void prepare(uint32_t frame, const Camera& camera, const RenderSettings& settings, VkRect2D area);
  /// Records the draws into a part of the target, inside a begun render pass.
  void record(VkCommandBuffer commands, uint32_t frame, VkRect2D area, DrawSlice slice = {}) const;
  /// The triangles the frame the last prepare() set up draws (the proxy's, the mesh's, or none).
  std::size_t prepared_triangles() const { return prepared_triangles_; }

  /// Version and tag of the geometry the last prepare() took for its frame (0: none yet).
  std::uint64_t drawn_geometry_version() const { return drawn_geometry_version_; }
  /// The tag of the geometry the last prepare() took (the publisher's label).
  std::uint64_t drawn_geometry_tag() const { return drawn_geometry_tag_; }
  /// Whether the frame the last prepare() set up draws the proxy: when its settings ask, or when
  /// its geometry holds only the proxy's vertices (GeometrySnapshot::only_vertices).
  bool prepared_proxy() const { return prepared_proxy_; }
  /// Whether the last prepare() set up exactly the picture of the prepare() before it (the same
  /// uniforms, geometry, field, classes, markers, triangles, pipelines and area), so that a target
  /// that kept that picture need not draw it again.
  bool prepared_as_before() const { return prepared_as_before_; }

 private:
  struct Frame {
    Buffer uniforms;
    VkDescriptorSet descriptor = VK_NULL_HANDLE;
    Buffer geometry;
    std::uint64_t geometry_version = 0;
    Buffer attributes;
    std::uint64_t attributes_version = 0;
    Buffer markers;
    std::uint64_t markers_version = 0;
    uint32_t marker_count = 0;
    RenderSettings settings;  ///< as prepared
    bool has_geometry = false;
    bool geometry_proxy_only = false;  ///< the geometry holds only the proxy's vertices: drawn as the proxy
    bool field_visible = false;
  };

  void create_pipelines(VkRenderPass render_pass, const PassFormat& format);
  Buffer index_buffer(const Eigen::MatrixXi& triangles) const;
  void release_mesh_buffers();

  const VulkanContext& context_;
  VkDescriptorSetLayout descriptor_layout_ = VK_NULL_HANDLE;
  VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
  VkPipelineLayout pipeline_layout_ = VK_NULL_HANDLE;
  VkPipeline surface_[2][2] = {};  ///< [flat shading][back faces culled]
  VkPipeline wireframe_ = VK_NULL_HANDLE;  ///< null where the device cannot draw lines of polygons
  VkPipeline ground_ = VK_NULL_HANDLE;
  VkPipeline markers_ = VK_NULL_HANDLE;
  VkPipeline legend_ = VK_NULL_HANDLE;
  std::vector<Frame> frames_;

  GeometryExchange* geometry_ = nullptr;
  Buffer indices_;
  uint32_t index_count_ = 0;
  Buffer proxy_indices_;
  uint32_t proxy_index_count_ = 0;
  std::size_t vertex_count_ = 0;
  Bounds rest_bounds_;
  bool closed_ = false;
  UpAxis up_ = UpAxis::Z;
  std::vector<float> attributes_;  ///< field, class (as bits) per vertex
  bool has_field_ = false;
  std::uint64_t attributes_version_ = 1;
  std::vector<Marker> markers_cpu_;
  std::uint64_t markers_version_ = 1;
  std::uint64_t drawn_geometry_version_ = 0;
  std::uint64_t drawn_geometry_tag_ = 0;
  bool prepared_proxy_ = false;
  std::size_t prepared_triangles_ = 0;
  std::uint64_t mesh_generation_ = 0;      ///< set_mesh calls: the mesh's triangles
  std::uint64_t proxy_generation_ = 0;     ///< set_proxy calls: the proxy's triangles
  std::vector<unsigned char> prepared_key_;  ///< what the last prepare() set up, byte for byte
  std::vector<unsigned char> previous_key_;  ///< the one before: storage for the next
  bool prepared_as_before_ = false;
};

}  // namespace hdeform::engine

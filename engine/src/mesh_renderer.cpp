#include "hdeform/engine/mesh_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

#include "hdeform/engine/closed_mesh.h"
#include "hdeform/engine/palette.h"
#include "hdeform/mesh.h"
#include "hdeform/trace.h"
#include "shaders/ground_frag.h"
#include "shaders/ground_vert.h"
#include "shaders/legend_frag.h"
#include "shaders/legend_vert.h"
#include "shaders/markers_frag.h"
#include "shaders/markers_vert.h"
#include "shaders/mesh_flat_frag.h"
#include "shaders/mesh_flat_vert.h"
#include "shaders/mesh_frag.h"
#include "shaders/mesh_vert.h"
#include "shaders/wire_frag.h"
#include "shaders/wire_vert.h"

namespace hdeform::engine {
namespace {

// Mirrors the FrameUniforms block of shaders/frame_uniforms.glsl (std140: every member 16-byte aligned).
struct FrameUniforms {
  float view_projection[16];
  float camera_position[4];
  float light_direction[4];
  float field_range[4];
  uint32_t flags[4];
  float base_color[4];
  float back_color[4];
  float ground_origin[4];
  float ground_u[4];
  float ground_v[4];
  float viewport[4];
  float class_colors[HD_CLASS_COLORS][4];
  float colormap[HD_COLORMAP_SAMPLES][4];
};
static_assert(sizeof(FrameUniforms) == 64 + 16 * (10 + HD_CLASS_COLORS + HD_COLORMAP_SAMPLES));

void store(float* out, const Eigen::Vector3f& v, float w) {
  out[0] = v.x();
  out[1] = v.y();
  out[2] = v.z();
  out[3] = w;
}

// A round grid spacing near `length`: 1, 2 or 5 times a power of ten.
float nice_spacing(float length) {
  const float power = std::pow(10.0f, std::floor(std::log10(length)));
  for (const float step : {1.0f, 2.0f, 5.0f}) {
    if (step * power >= length) return step * power;
  }
  return 10.0f * power;
}

VkShaderModule create_module(VkDevice device, std::span<const uint32_t> code) {
  VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = code.size_bytes();
  info.pCode = code.data();
  VkShaderModule module = VK_NULL_HANDLE;
  check(vkCreateShaderModule(device, &info, nullptr, &module), "vkCreateShaderModule");
  return module;
}

struct PipelineSpec {
  std::span<const uint32_t> vertex;
  std::span<const uint32_t> fragment;
  std::vector<VkVertexInputBindingDescription> bindings;
  std::vector<VkVertexInputAttributeDescription> attributes;
  VkPolygonMode polygon_mode = VK_POLYGON_MODE_FILL;
  bool depth_test = true;
  bool depth_write = true;
  VkCompareOp depth_compare = VK_COMPARE_OP_LESS;
  bool depth_bias = false;
  bool blend = false;
  VkCullModeFlags cull = VK_CULL_MODE_NONE;
};

VkPipeline create_pipeline(VkDevice device, VkPipelineLayout layout, VkRenderPass pass, VkSampleCountFlagBits samples, const PipelineSpec& spec) {
  const VkShaderModule vertex = create_module(device, spec.vertex);
  const VkShaderModule fragment = create_module(device, spec.fragment);
  std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
  stages[0] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT, vertex, "main", nullptr};
  stages[1] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT, fragment, "main", nullptr};
  VkPipelineVertexInputStateCreateInfo input{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  input.vertexBindingDescriptionCount = static_cast<uint32_t>(spec.bindings.size());
  input.pVertexBindingDescriptions = spec.bindings.data();
  input.vertexAttributeDescriptionCount = static_cast<uint32_t>(spec.attributes.size());
  input.pVertexAttributeDescriptions = spec.attributes.data();
  VkPipelineInputAssemblyStateCreateInfo assembly{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  raster.polygonMode = spec.polygon_mode;
  raster.cullMode = spec.cull;
  raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.lineWidth = 1.0f;
  raster.depthBiasEnable = spec.depth_bias ? VK_TRUE : VK_FALSE;
  raster.depthBiasConstantFactor = 1.0f;  // the surface sits just behind its own wireframe
  raster.depthBiasSlopeFactor = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  multisample.rasterizationSamples = samples;
  VkPipelineDepthStencilStateCreateInfo depth{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  depth.depthTestEnable = spec.depth_test ? VK_TRUE : VK_FALSE;
  depth.depthWriteEnable = spec.depth_write ? VK_TRUE : VK_FALSE;
  depth.depthCompareOp = spec.depth_compare;
  VkPipelineColorBlendAttachmentState blend{};
  blend.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  if (spec.blend) {
    blend.blendEnable = VK_TRUE;
    blend.srcColorBlendFactor = VK_BLEND_FACTOR_SRC_ALPHA;
    blend.dstColorBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
    blend.colorBlendOp = VK_BLEND_OP_ADD;
    blend.srcAlphaBlendFactor = VK_BLEND_FACTOR_ZERO;
    blend.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
    blend.alphaBlendOp = VK_BLEND_OP_ADD;
  }
  VkPipelineColorBlendStateCreateInfo blending{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  blending.attachmentCount = 1;
  blending.pAttachments = &blend;
  const std::array<VkDynamicState, 2> dynamic_states{VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dynamic.dynamicStateCount = static_cast<uint32_t>(dynamic_states.size());
  dynamic.pDynamicStates = dynamic_states.data();
  VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  info.stageCount = static_cast<uint32_t>(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = &input;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth;
  info.pColorBlendState = &blending;
  info.pDynamicState = &dynamic;
  info.layout = layout;
  info.renderPass = pass;
  VkPipeline pipeline = VK_NULL_HANDLE;
  const VkResult result = vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline);
  vkDestroyShaderModule(device, vertex, nullptr);
  vkDestroyShaderModule(device, fragment, nullptr);
  check(result, "vkCreateGraphicsPipelines");
  return pipeline;
}

template <std::size_t N>
std::span<const uint32_t> code(const uint32_t (&words)[N]) {
  return {words, N};
}

std::vector<VkVertexInputBindingDescription> mesh_bindings() {
  return {{HD_VERTEX_BINDING_GEOMETRY, 6 * sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX},
          {HD_VERTEX_BINDING_ATTRIBUTES, 2 * sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX}};
}

std::vector<VkVertexInputAttributeDescription> mesh_attributes() {
  return {{0, HD_VERTEX_BINDING_GEOMETRY, VK_FORMAT_R32G32B32_SFLOAT, 0},
          {1, HD_VERTEX_BINDING_GEOMETRY, VK_FORMAT_R32G32B32_SFLOAT, 3 * sizeof(float)},
          {2, HD_VERTEX_BINDING_ATTRIBUTES, VK_FORMAT_R32_SFLOAT, 0},
          {3, HD_VERTEX_BINDING_ATTRIBUTES, VK_FORMAT_R32_UINT, sizeof(float)}};
}

// A picture's parts (DrawSlice) in units of the smallest: part k < ramp is 2^k of them and
// every later one 2^ramp. The units in the parts before `part`.
std::uint64_t units_before(int part, int ramp) {
  const int ramped = std::min(part, ramp);
  return ((std::uint64_t{1} << ramped) - 1) + static_cast<std::uint64_t>(part - ramped) * (std::uint64_t{1} << ramp);
}

}  // namespace

double share_before(const DrawSlice& slice) {
  return static_cast<double>(units_before(slice.index, slice.ramp)) / static_cast<double>(units_before(slice.count, slice.ramp));
}

MeshRenderer::MeshRenderer(const VulkanContext& context, VkRenderPass render_pass, const PassFormat& format, uint32_t frames_in_flight)
    : context_(context), frames_(frames_in_flight) {
  const VkDevice device = context.device();
  VkDescriptorSetLayoutBinding binding{};
  binding.binding = HD_BINDING_FRAME_UNIFORMS;
  binding.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  binding.descriptorCount = 1;
  binding.stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  VkDescriptorSetLayoutCreateInfo layout_info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  layout_info.bindingCount = 1;
  layout_info.pBindings = &binding;
  check(vkCreateDescriptorSetLayout(device, &layout_info, nullptr, &descriptor_layout_), "vkCreateDescriptorSetLayout");
  VkDescriptorPoolSize pool_size{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, frames_in_flight};
  VkDescriptorPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pool_info.maxSets = frames_in_flight;
  pool_info.poolSizeCount = 1;
  pool_info.pPoolSizes = &pool_size;
  check(vkCreateDescriptorPool(device, &pool_info, nullptr, &descriptor_pool_), "vkCreateDescriptorPool");
  VkPipelineLayoutCreateInfo pipeline_layout_info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pipeline_layout_info.setLayoutCount = 1;
  pipeline_layout_info.pSetLayouts = &descriptor_layout_;
  check(vkCreatePipelineLayout(device, &pipeline_layout_info, nullptr, &pipeline_layout_), "vkCreatePipelineLayout");
  create_pipelines(render_pass, format);

  for (auto& frame : frames_) {
    frame.uniforms = context.create_buffer(sizeof(FrameUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    VkDescriptorSetAllocateInfo allocation{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocation.descriptorPool = descriptor_pool_;
    allocation.descriptorSetCount = 1;
    allocation.pSetLayouts = &descriptor_layout_;
    check(vkAllocateDescriptorSets(device, &allocation, &frame.descriptor), "vkAllocateDescriptorSets");
    VkDescriptorBufferInfo buffer_info{frame.uniforms.buffer, 0, sizeof(FrameUniforms)};
    VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    write.dstSet = frame.descriptor;
    write.dstBinding = HD_BINDING_FRAME_UNIFORMS;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    write.pBufferInfo = &buffer_info;
    vkUpdateDescriptorSets(device, 1, &write, 0, nullptr);
  }
}

void MeshRenderer::create_pipelines(VkRenderPass render_pass, const PassFormat& format) {
  const VkDevice device = context_.device();
  const auto samples = format.samples;
  for (const int flat : {0, 1}) {
    for (const int cull : {0, 1}) {
      PipelineSpec surface{flat ? code(hdeform_spirv_mesh_flat_vert) : code(hdeform_spirv_mesh_vert),
                           flat ? code(hdeform_spirv_mesh_flat_frag) : code(hdeform_spirv_mesh_frag), mesh_bindings(),
                           mesh_attributes()};
      surface.depth_bias = true;
      surface.cull = cull ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE;
      surface_[flat][cull] = create_pipeline(device, pipeline_layout_, render_pass, samples, surface);
    }
  }

  VkPhysicalDeviceFeatures features{};
  vkGetPhysicalDeviceFeatures(context_.physical_device(), &features);
  if (features.fillModeNonSolid) {
    PipelineSpec wire{code(hdeform_spirv_wire_vert), code(hdeform_spirv_wire_frag),
                      {{HD_VERTEX_BINDING_GEOMETRY, 6 * sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX}},
                      {{0, HD_VERTEX_BINDING_GEOMETRY, VK_FORMAT_R32G32B32_SFLOAT, 0}}};
    wire.polygon_mode = VK_POLYGON_MODE_LINE;
    wire.depth_write = false;
    wire.depth_compare = VK_COMPARE_OP_LESS_OR_EQUAL;
    wireframe_ = create_pipeline(device, pipeline_layout_, render_pass, samples, wire);
  }

  PipelineSpec ground{code(hdeform_spirv_ground_vert), code(hdeform_spirv_ground_frag)};
  ground.depth_write = false;
  ground.blend = true;
  ground_ = create_pipeline(device, pipeline_layout_, render_pass, samples, ground);

  PipelineSpec markers{code(hdeform_spirv_markers_vert), code(hdeform_spirv_markers_frag),
                       {{HD_VERTEX_BINDING_MARKERS, sizeof(Marker), VK_VERTEX_INPUT_RATE_INSTANCE}},
                       {{0, HD_VERTEX_BINDING_MARKERS, VK_FORMAT_R32G32B32_SFLOAT, offsetof(Marker, position)},
                        {1, HD_VERTEX_BINDING_MARKERS, VK_FORMAT_R32_UINT, offsetof(Marker, color)}}};
  markers_ = create_pipeline(device, pipeline_layout_, render_pass, samples, markers);

  PipelineSpec legend{code(hdeform_spirv_legend_vert), code(hdeform_spirv_legend_frag)};
  legend.depth_test = false;
  legend.depth_write = false;
  legend_ = create_pipeline(device, pipeline_layout_, render_pass, samples, legend);
}

MeshRenderer::~MeshRenderer() {
  const VkDevice device = context_.device();
  vkDeviceWaitIdle(device);
  release_mesh_buffers();
  for (auto& frame : frames_) context_.destroy(frame.uniforms);
  for (const VkPipeline pipeline : {surface_[0][0], surface_[0][1], surface_[1][0], surface_[1][1], wireframe_, ground_,
                                    markers_, legend_}) {
    if (pipeline != VK_NULL_HANDLE) vkDestroyPipeline(device, pipeline, nullptr);
  }
  vkDestroyPipelineLayout(device, pipeline_layout_, nullptr);
  vkDestroyDescriptorPool(device, descriptor_pool_, nullptr);
  vkDestroyDescriptorSetLayout(device, descriptor_layout_, nullptr);
}

void MeshRenderer::release_mesh_buffers() {
  context_.destroy(indices_);
  context_.destroy(proxy_indices_);
  proxy_index_count_ = 0;
  for (auto& frame : frames_) {
    context_.destroy(frame.geometry);
    context_.destroy(frame.attributes);
    context_.destroy(frame.markers);
    frame.geometry_version = frame.attributes_version = frame.markers_version = 0;
    frame.geometry_proxy_only = false;
    frame.marker_count = 0;
  }
}

void MeshRenderer::set_mesh(const Eigen::MatrixXi& triangles, GeometryExchange& geometry, const Bounds& rest, UpAxis up, std::optional<bool> closed) {
  auto buffers = std::make_unique<MeshBuffers>(context_, geometry.vertex_count(), static_cast<std::size_t>(triangles.rows()), frame_count());
  // The newest geometry written now, as the first prepare() would (this is the reading thread):
  // then that frame uploads nothing, and the buffers' pages are written once.
  buffers->fill(triangles, geometry.acquire());
  set_mesh(std::move(buffers), geometry, rest, up, closed ? *closed : every_edge_has_its_reverse(triangles, static_cast<Eigen::Index>(geometry.vertex_count())));
}

void MeshRenderer::set_mesh(std::unique_ptr<MeshBuffers> buffers, GeometryExchange& geometry, const Bounds& rest, UpAxis up, bool closed) {
  if (!buffers || !buffers->filled() || buffers->frames() != frame_count() || buffers->vertex_count() != geometry.vertex_count()) {
    throw std::logic_error("MeshRenderer::set_mesh: buffers unfilled, or made for other frames or another vertex count");
  }
  vkDeviceWaitIdle(context_.device());
  release_mesh_buffers();
  geometry_ = &geometry;
  vertex_count_ = geometry.vertex_count();
  rest_bounds_ = rest;
  up_ = up;
  index_count_ = static_cast<uint32_t>(3 * buffers->triangle_count());
  std::swap(indices_, buffers->indices_);
  closed_ = closed;
  for (std::size_t f = 0; f < frames_.size(); ++f) {
    Frame& frame = frames_[f];
    MeshBuffers::Frame& made = buffers->frames_[f];
    std::swap(frame.geometry, made.geometry);
    std::swap(frame.attributes, made.attributes);
    frame.geometry_version = made.geometry_version;
  }
  attributes_ = std::move(buffers->attributes_);
  has_field_ = false;
  // The buffers hold these attributes (none) already.
  ++attributes_version_;
  for (Frame& frame : frames_) frame.attributes_version = attributes_version_;
  markers_cpu_.clear();
  ++markers_version_;
  ++mesh_generation_;
}

Buffer MeshRenderer::index_buffer(const Eigen::MatrixXi& triangles) const {
  Buffer buffer = context_.create_buffer(sizeof(uint32_t) * static_cast<std::size_t>(triangles.size()), VK_BUFFER_USAGE_INDEX_BUFFER_BIT);
  auto* out = static_cast<uint32_t*>(buffer.mapped);
  for (Eigen::Index t = 0; t < triangles.rows(); ++t) {
    for (int k = 0; k < 3; ++k) *out++ = static_cast<uint32_t>(triangles(t, k));
  }
  return buffer;
}

void MeshRenderer::set_proxy(const Eigen::MatrixXi& triangles) {
  validate_triangles(triangles, static_cast<Eigen::Index>(vertex_count_), "proxy to draw");
  vkDeviceWaitIdle(context_.device());
  context_.destroy(proxy_indices_);
  proxy_index_count_ = 0;
  ++proxy_generation_;
  if (triangles.rows() == 0) return;
  proxy_indices_ = index_buffer(triangles);
  proxy_index_count_ = static_cast<uint32_t>(triangles.size());
}

// The attributes change (and the scene is drawn again) only where a value does: the editor sets
// them again whenever the solver's state changes, mostly to the same values.
void MeshRenderer::set_field(std::span<const float> values) {
  const bool has_field = !values.empty() && values.size() == vertex_count_;
  bool changed = has_field != has_field_;
  has_field_ = has_field;
  for (std::size_t v = 0; v < vertex_count_; ++v) {
    const float value = has_field_ ? values[v] : 0.0f;
    changed = changed || std::memcmp(&attributes_[2 * v], &value, sizeof value) != 0;
    attributes_[2 * v] = value;
  }
  if (changed) ++attributes_version_;
}

void MeshRenderer::set_classes(std::span<const uint32_t> classes) {
  bool changed = false;
  for (std::size_t v = 0; v < vertex_count_; ++v) {
    const uint32_t value = v < classes.size() ? classes[v] : HD_CLASS_FREE;
    changed = changed || std::memcmp(&attributes_[2 * v + 1], &value, sizeof value) != 0;
    std::memcpy(&attributes_[2 * v + 1], &value, sizeof value);
  }
  if (changed) ++attributes_version_;
}

void MeshRenderer::set_markers(std::span<const Marker> markers) {
  markers_cpu_.assign(markers.begin(), markers.end());
  ++markers_version_;
}

void MeshRenderer::prepare(uint32_t frame_index, const Camera& camera, const RenderSettings& settings, VkRect2D area) {
  const VkExtent2D extent = area.extent;
  Frame& frame = frames_[frame_index];
  frame.settings = settings;
  frame.has_geometry = false;
  if (geometry_ != nullptr) {
    if (const GeometrySnapshot* snapshot = geometry_->acquire()) {
      if (snapshot->version != frame.geometry_version) {
        const trace::Scope traced("geometry uploaded", "frame");
        if (snapshot->only_vertices) {
          // The proxy's vertices alone: the frame draws nothing else of this geometry.
          auto* to = static_cast<float*>(frame.geometry.mapped);
          for (const int v : *snapshot->only_vertices) std::memcpy(to + 6 * v, snapshot->position_normal.data() + 6 * v, sizeof(float) * 6);
        } else {
          std::memcpy(frame.geometry.mapped, snapshot->position_normal.data(), sizeof(float) * snapshot->position_normal.size());
        }
        frame.geometry_version = snapshot->version;
        frame.geometry_proxy_only = snapshot->only_vertices != nullptr;
      }
      frame.has_geometry = true;
      drawn_geometry_version_ = frame.geometry_version;
      drawn_geometry_tag_ = snapshot->tag;
    }
  }
  prepared_proxy_ = frame.has_geometry && proxy_index_count_ > 0 && (settings.proxy || frame.geometry_proxy_only);
  prepared_triangles_ = !frame.has_geometry ? 0 : (prepared_proxy_ ? proxy_index_count_ : index_count_) / 3;
  if (frame.attributes_version != attributes_version_ && frame.attributes.mapped != nullptr) {
    const trace::Scope traced("classes and field uploaded", "frame");
    std::memcpy(frame.attributes.mapped, attributes_.data(), sizeof(float) * attributes_.size());
    frame.attributes_version = attributes_version_;
  }
  if (frame.markers_version != markers_version_) {
    if (frame.markers.size < sizeof(Marker) * markers_cpu_.size() || frame.markers.buffer == VK_NULL_HANDLE) {
      context_.destroy(frame.markers);  // this frame's previous submission has completed
      frame.markers = context_.create_buffer(sizeof(Marker) * std::max<std::size_t>(markers_cpu_.size(), 16), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
    }
    if (!markers_cpu_.empty()) std::memcpy(frame.markers.mapped, markers_cpu_.data(), sizeof(Marker) * markers_cpu_.size());
    frame.marker_count = static_cast<uint32_t>(markers_cpu_.size());
    frame.markers_version = markers_version_;
  }
  frame.field_visible = settings.show_field && has_field_;

  FrameUniforms u{};
  const float aspect = static_cast<float>(extent.width) / static_cast<float>(std::max(extent.height, 1u));
  const Eigen::Matrix4f view_projection = camera.view_projection(aspect);
  std::memcpy(u.view_projection, view_projection.data(), sizeof u.view_projection);
  const Eigen::Vector3f eye = camera.position();
  const Eigen::Vector3f forward = (camera.target - eye).normalized();
  store(u.camera_position, -forward, 0.0f);
  const Eigen::Vector3f right = forward.cross(camera.up_vector()).normalized();
  const Eigen::Vector3f light = (-0.45f * forward + 0.75f * camera.up_vector() - 0.35f * right).normalized();
  store(u.light_direction, light, 0.0f);
  u.field_range[0] = settings.field_min;
  u.field_range[1] = settings.field_max;
  u.field_range[2] = settings.isoline_step;
  u.field_range[3] = settings.isoline_width;
  u.flags[0] = (frame.field_visible ? HD_SHOW_FIELD : 0u) | (settings.show_classes ? HD_SHOW_CLASSES : 0u) |
               (settings.flat_shading ? HD_FLAT_SHADING : 0u) | (settings.lighting ? HD_LIGHTING : 0u) |
               (settings.ground ? HD_SHOW_GROUND : 0u) | (settings.legend && frame.field_visible ? HD_SHOW_LEGEND : 0u);
  store(u.base_color, {0.80f, 0.78f, 0.74f}, 1.0f);
  store(u.back_color, {0.62f, 0.22f, 0.45f}, 0.65f);
  // Ground: a square under the rest shape, perpendicular to the up axis.
  const Eigen::Vector3f up = camera.up_vector();
  const Eigen::Vector3f axis_u = up == Eigen::Vector3f::UnitZ() ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitZ();
  const Eigen::Vector3f axis_v = up.cross(axis_u);
  const float radius = std::max(rest_bounds_.radius(), 1e-6f);
  const Eigen::Vector3f center = rest_bounds_.center();
  const Eigen::Vector3f origin = center - up * (center.dot(up) - rest_bounds_.min.dot(up));
  store(u.ground_origin, origin, nice_spacing(radius / 4.0f));
  store(u.ground_u, axis_u, 2.5f * radius);
  store(u.ground_v, axis_v, 2.2f * radius);
  u.viewport[0] = static_cast<float>(extent.width);
  u.viewport[1] = static_cast<float>(extent.height);
  for (std::size_t k = 0; k < class_colors().size(); ++k) store(u.class_colors[k], class_colors()[k], 1.0f);
  for (std::size_t k = 0; k < colormap_samples().size(); ++k) store(u.colormap[k], colormap_samples()[k], 1.0f);
  std::memcpy(frame.uniforms.mapped, &u, sizeof u);

  // What record() will draw from this, byte for byte: the uniforms and what else it reads.
  // (Into the storage of the key before last: no allocation once the sizes settle.)
  std::vector<unsigned char>& key = previous_key_;
  key.resize(sizeof u);
  std::memcpy(key.data(), &u, sizeof u);
  auto append = [&key](const auto& value) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(&value);
    key.insert(key.end(), bytes, bytes + sizeof value);
  };
  append(frame.has_geometry);
  append(frame.geometry_version);
  append(prepared_proxy_);
  append(attributes_version_);
  append(markers_version_);
  append(frame.marker_count);
  append(mesh_generation_);
  if (prepared_proxy_) append(proxy_generation_);  // a new proxy changes nothing until it is drawn
  append(settings.wireframe);
  append(settings.back_faces);
  append(area.offset.x);
  append(area.offset.y);
  append(area.extent.width);
  append(area.extent.height);
  prepared_as_before_ = key == prepared_key_;
  std::swap(prepared_key_, previous_key_);
}

void MeshRenderer::record(VkCommandBuffer commands, uint32_t frame_index, VkRect2D area, DrawSlice slice) const {
  if (slice.count < 1 || slice.index < 0 || slice.index >= slice.count || slice.ramp < 0 || slice.ramp > 16) {
    throw std::logic_error("MeshRenderer::record: part " + std::to_string(slice.index) + " of " + std::to_string(slice.count) + ", ramp " +
                           std::to_string(slice.ramp));
  }
  const bool last_slice = slice.index == slice.count - 1;
  const Frame& frame = frames_[frame_index];
  const VkViewport viewport{static_cast<float>(area.offset.x), static_cast<float>(area.offset.y), static_cast<float>(area.extent.width),
                            static_cast<float>(area.extent.height), 0.0f, 1.0f};
  const VkRect2D scissor = area;
  vkCmdSetViewport(commands, 0, 1, &viewport);
  vkCmdSetScissor(commands, 0, 1, &scissor);
  vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_layout_, 0, 1, &frame.descriptor, 0, nullptr);

  if (frame.has_geometry && index_count_ > 0) {
    const std::array<VkBuffer, 2> buffers{frame.geometry.buffer, frame.attributes.buffer};
    const std::array<VkDeviceSize, 2> offsets{0, 0};
    vkCmdBindVertexBuffers(commands, HD_VERTEX_BINDING_GEOMETRY, 2, buffers.data(), offsets.data());
    const bool proxy = (frame.settings.proxy || frame.geometry_proxy_only) && proxy_index_count_ > 0;
    // The whole picture's draws in order, the surface's triangles and then the wireframe's, cut
    // into parts (units_before).
    const std::uint64_t triangles = (proxy ? proxy_index_count_ : index_count_) / 3;
    const bool wireframe = frame.settings.wireframe && wireframe_ != VK_NULL_HANDLE;
    const std::uint64_t all = triangles * (wireframe ? 2 : 1);
    const std::uint64_t units = units_before(slice.count, slice.ramp);
    const std::uint64_t from = all * units_before(slice.index, slice.ramp) / units;
    const std::uint64_t to = all * units_before(slice.index + 1, slice.ramp) / units;
    const auto draw = [&](std::uint64_t first, std::uint64_t end) {
      if (end > first) vkCmdDrawIndexed(commands, static_cast<uint32_t>(3 * (end - first)), 1, static_cast<uint32_t>(3 * first), 0, 0);
    };
    vkCmdBindIndexBuffer(commands, proxy ? proxy_indices_.buffer : indices_.buffer, 0, VK_INDEX_TYPE_UINT32);
    if (from < triangles) {
      using BackFaces = RenderSettings::BackFaces;
      const bool cull = frame.settings.back_faces == BackFaces::Cull || (frame.settings.back_faces == BackFaces::Auto && closed_);
      vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, surface_[frame.settings.flat_shading ? 1 : 0][cull ? 1 : 0]);
      draw(from, std::min(to, triangles));
    }
    if (to > triangles) {
      vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, wireframe_);
      draw(std::max(from, triangles) - triangles, to - triangles);
    }
  }
  if (!last_slice) return;
  if (frame.settings.ground) {
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, ground_);
    vkCmdDraw(commands, 6, 1, 0, 0);
  }
  if (frame.marker_count > 0) {
    const VkDeviceSize offset = 0;
    vkCmdBindVertexBuffers(commands, HD_VERTEX_BINDING_MARKERS, 1, &frame.markers.buffer, &offset);
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, markers_);
    vkCmdDraw(commands, 6, frame.marker_count, 0, 0);
  }
  if (frame.field_visible && frame.settings.legend) {
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, legend_);
    vkCmdDraw(commands, 6, 1, 0, 0);
  }
}

}  // namespace hdeform::engine

#include "hdeform/engine/render_targets.h"

#include <array>
#include <span>
#include <cstring>
#include <stdexcept>

namespace hdeform::engine {

VkFormat choose_depth_format(const VulkanContext& context) {
  for (const VkFormat format : {VK_FORMAT_D32_SFLOAT, VK_FORMAT_D24_UNORM_S8_UINT, VK_FORMAT_D16_UNORM}) {
    VkFormatProperties properties;
    vkGetPhysicalDeviceFormatProperties(context.physical_device(), format, &properties);
    if (properties.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT) return format;
  }
  throw RenderError("the Vulkan device has no depth format to render to");
}

namespace {

// One subpass over `attachments`.
VkRenderPass create_render_pass(const VulkanContext& context, std::span<const VkAttachmentDescription> attachments, const VkSubpassDescription& subpass,
                                std::span<const VkSubpassDependency> dependencies) {
  VkRenderPassCreateInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  info.attachmentCount = static_cast<uint32_t>(attachments.size());
  info.pAttachments = attachments.data();
  info.subpassCount = 1;
  info.pSubpasses = &subpass;
  info.dependencyCount = static_cast<uint32_t>(dependencies.size());
  info.pDependencies = dependencies.data();
  VkRenderPass pass = VK_NULL_HANDLE;
  check(vkCreateRenderPass(context.device(), &info, nullptr, &pass), "vkCreateRenderPass");
  return pass;
}

// The pass's colour writes finish before a copy or a presentation reads the image.
VkSubpassDependency written_before_copy_or_presentation() {
  VkSubpassDependency dependency{};
  dependency.srcSubpass = 0;
  dependency.dstSubpass = VK_SUBPASS_EXTERNAL;
  dependency.srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  dependency.dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT;
  dependency.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  dependency.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  return dependency;
}

}  // namespace

VkRenderPass create_scene_render_pass(const VulkanContext& context, const PassFormat& format, VkImageLayout final_layout, ScenePass pass) {
  const bool multisampled = format.samples != VK_SAMPLE_COUNT_1_BIT;
  if (multisampled && pass != ScenePass::Whole) throw std::logic_error("a scene is drawn in slices only single-sampled");
  const bool continues = pass == ScenePass::NextSlice;
  std::vector<VkAttachmentDescription> attachments;
  VkAttachmentDescription color{};
  color.format = format.color;
  color.samples = format.samples;
  color.loadOp = continues ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR;
  color.storeOp = multisampled ? VK_ATTACHMENT_STORE_OP_DONT_CARE : VK_ATTACHMENT_STORE_OP_STORE;
  color.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  color.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  color.initialLayout = continues ? final_layout : VK_IMAGE_LAYOUT_UNDEFINED;
  color.finalLayout = multisampled ? VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL : final_layout;
  attachments.push_back(color);
  VkAttachmentDescription depth = color;
  depth.format = format.depth;
  depth.storeOp = pass == ScenePass::Whole ? VK_ATTACHMENT_STORE_OP_DONT_CARE : VK_ATTACHMENT_STORE_OP_STORE;
  depth.initialLayout = continues ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED;
  depth.finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  attachments.push_back(depth);
  if (multisampled) {
    VkAttachmentDescription resolve = color;
    resolve.samples = VK_SAMPLE_COUNT_1_BIT;
    resolve.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    resolve.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    resolve.finalLayout = final_layout;
    attachments.push_back(resolve);
  }
  const VkAttachmentReference color_reference{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  const VkAttachmentReference depth_reference{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  const VkAttachmentReference resolve_reference{2, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass{};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = 1;
  subpass.pColorAttachments = &color_reference;
  subpass.pDepthStencilAttachment = &depth_reference;
  subpass.pResolveAttachments = multisampled ? &resolve_reference : nullptr;
  // Earlier use of the attachments (the previous frame, a presentation, a copy out of the
  // image) finishes before we write; our writes finish before a copy or a presentation reads them.
  std::array<VkSubpassDependency, 2> dependencies{};
  dependencies[0].srcSubpass = VK_SUBPASS_EXTERNAL;
  dependencies[0].dstSubpass = 0;
  dependencies[0].srcStageMask =
      VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
  dependencies[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT;
  dependencies[0].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  dependencies[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_READ_BIT |
                                  VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT;
  dependencies[1] = written_before_copy_or_presentation();
  return create_render_pass(context, attachments, subpass, dependencies);
}

VkRenderPass create_overlay_render_pass(const VulkanContext& context, VkFormat format) {
  VkAttachmentDescription color{};
  color.format = format;
  color.samples = VK_SAMPLE_COUNT_1_BIT;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  color.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  color.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  color.initialLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  color.finalLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  const VkAttachmentReference reference{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass{};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = 1;
  subpass.pColorAttachments = &reference;
  // The copy of the scene finishes before the interface is drawn over it; the drawing finishes
  // before a screenshot's copy or the presentation reads the image.
  std::array<VkSubpassDependency, 2> dependencies{};
  dependencies[0].srcSubpass = VK_SUBPASS_EXTERNAL;
  dependencies[0].dstSubpass = 0;
  dependencies[0].srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
  dependencies[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  dependencies[0].srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  dependencies[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  dependencies[1] = written_before_copy_or_presentation();
  return create_render_pass(context, std::span(&color, 1), subpass, dependencies);
}

void SceneAttachments::create(const VulkanContext& context, const PassFormat& format, VkExtent2D extent) {
  if (format.samples != VK_SAMPLE_COUNT_1_BIT) {
    multisampled_color = context.create_image(extent.width, extent.height, format.color,
                                              VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT,
                                              format.samples, VK_IMAGE_ASPECT_COLOR_BIT);
  }
  depth = context.create_image(extent.width, extent.height, format.depth, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, format.samples,
                               VK_IMAGE_ASPECT_DEPTH_BIT);
}

void SceneAttachments::destroy(const VulkanContext& context) {
  context.destroy(multisampled_color);
  context.destroy(depth);
}

std::vector<VkImageView> SceneAttachments::views(const PassFormat& format, VkImageView target) const {
  if (format.samples == VK_SAMPLE_COUNT_1_BIT) return {target, depth.view};
  return {multisampled_color.view, depth.view, target};
}

VkFramebuffer create_framebuffer(const VulkanContext& context, VkRenderPass pass, std::span<const VkImageView> views, VkExtent2D extent) {
  VkFramebufferCreateInfo info{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  info.renderPass = pass;
  info.attachmentCount = static_cast<uint32_t>(views.size());
  info.pAttachments = views.data();
  info.width = extent.width;
  info.height = extent.height;
  info.layers = 1;
  VkFramebuffer framebuffer = VK_NULL_HANDLE;
  check(vkCreateFramebuffer(context.device(), &info, nullptr, &framebuffer), "vkCreateFramebuffer");
  return framebuffer;
}

void begin_scene_pass(VkCommandBuffer commands, VkRenderPass pass, VkFramebuffer framebuffer, VkExtent2D extent) {
  std::array<VkClearValue, 3> clear{};
  clear[0].color = {{kBackground[0], kBackground[1], kBackground[2], 1.0f}};
  clear[1].depthStencil = {1.0f, 0};
  clear[2].color = clear[0].color;
  VkRenderPassBeginInfo begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  begin.renderPass = pass;
  begin.framebuffer = framebuffer;
  begin.renderArea = {{0, 0}, extent};
  begin.clearValueCount = static_cast<uint32_t>(clear.size());
  begin.pClearValues = clear.data();
  vkCmdBeginRenderPass(commands, &begin, VK_SUBPASS_CONTENTS_INLINE);
}

OffscreenTarget::OffscreenTarget(const VulkanContext& context, uint32_t width, uint32_t height, int samples)
    : context_(context), extent_{width, height} {
  if (width == 0 || height == 0 || width > 16384 || height > 16384) {
    throw RenderError("image size " + std::to_string(width) + "x" + std::to_string(height) + " is out of range (1 to 16384)");
  }
  format_.depth = choose_depth_format(context);
  format_.samples = context.supported_samples(samples);
  try {
    render_pass_ = create_scene_render_pass(context, format_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    attachments_.create(context, format_, extent_);
    color_ = context.create_image(width, height, format_.color, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                  VK_SAMPLE_COUNT_1_BIT, VK_IMAGE_ASPECT_COLOR_BIT);
    framebuffer_ = create_framebuffer(context, render_pass_, attachments_.views(format_, color_.view), extent_);
    readback_ = context.create_buffer(VkDeviceSize{width} * height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  } catch (...) {
    release();
    throw;
  }
}

OffscreenTarget::~OffscreenTarget() { release(); }

void OffscreenTarget::release() {
  const VkDevice device = context_.device();
  vkDeviceWaitIdle(device);
  if (framebuffer_ != VK_NULL_HANDLE) vkDestroyFramebuffer(device, framebuffer_, nullptr);
  framebuffer_ = VK_NULL_HANDLE;
  context_.destroy(readback_);
  context_.destroy(color_);
  attachments_.destroy(context_);
  if (render_pass_ != VK_NULL_HANDLE) vkDestroyRenderPass(device, render_pass_, nullptr);
  render_pass_ = VK_NULL_HANDLE;
}

void OffscreenTarget::begin(VkCommandBuffer commands) { begin_scene_pass(commands, render_pass_, framebuffer_, extent_); }

void OffscreenTarget::finish(VkCommandBuffer commands) {
  vkCmdEndRenderPass(commands);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {extent_.width, extent_.height, 1};
  vkCmdCopyImageToBuffer(commands, color_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback_.buffer, 1, &region);
  VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

Pixels OffscreenTarget::pixels() const {
  Pixels pixels{extent_.width, extent_.height, std::vector<uint8_t>(std::size_t{extent_.width} * extent_.height * 4)};
  std::memcpy(pixels.rgba.data(), readback_.mapped, pixels.rgba.size());
  return pixels;
}

}  // namespace hdeform::engine

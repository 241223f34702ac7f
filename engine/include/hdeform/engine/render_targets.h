#pragma once
/// @file
/// Where frames go. Both targets draw the scene with one render pass layout — multisampled colour
/// and depth, resolved into a single-sampled image — so the same pipelines draw into either:
///   OffscreenTarget: an image read back to memory (no window system, no X server);
///   SwapchainTarget: a window's swapchain (see swapchain_target.h).
#include <cstdint>
#include <span>
#include <vector>

#include "hdeform/engine/vulkan_context.h"

namespace hdeform::engine {

/// The formats and sample count of a scene render pass.
struct PassFormat {
  VkFormat color = VK_FORMAT_R8G8B8A8_UNORM;
  VkFormat depth = VK_FORMAT_D32_SFLOAT;
  VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;
};

/// A depth format the device can render to.
VkFormat choose_depth_format(const VulkanContext& context);

/// How a scene pass starts and ends. A picture may be drawn in slices over several passes (on a
/// CPU device a frame of every triangle of a scan takes a second, which the window need not wait
/// for): the first slice clears, each later one draws over what the earlier ones left, colour and
/// depth. Slices need a single-sampled pass. All three are compatible with one another, so the
/// same pipelines and framebuffers serve them.
enum class ScenePass {
  Whole,       ///< clears colour and depth; the depth is not kept
  FirstSlice,  ///< clears colour and depth, and keeps the depth for the next slice
  NextSlice,   ///< draws over the colour and depth a slice before it left
};

/// Clears colour and depth (or, for NextSlice, loads them), draws, resolves (when multisampled)
/// into the single-sampled colour attachment, which ends in `final_layout`.
VkRenderPass create_scene_render_pass(const VulkanContext& context, const PassFormat& format, VkImageLayout final_layout,
                                      ScenePass pass = ScenePass::Whole);

/// The user interface over a scene: one single-sampled colour attachment of `color`, which holds
/// the scene copied into it (loaded from the transfer layout), drawn over and left ready to present
/// (or to copy for a screenshot first).
VkRenderPass create_overlay_render_pass(const VulkanContext& context, VkFormat color);

/// The multisampled colour and the depth image of one framebuffer size.
struct SceneAttachments {
  Image multisampled_color;  ///< only when samples > 1
  Image depth;
  /// Creates the attachments for a framebuffer of `extent`.
  void create(const VulkanContext& context, const PassFormat& format, VkExtent2D extent);
  /// Destroys them.
  void destroy(const VulkanContext& context);
  /// Framebuffer attachments in render pass order, around the single-sampled `target` view.
  std::vector<VkImageView> views(const PassFormat& format, VkImageView target) const;
};

/// The neutral background every picture is cleared to.
inline constexpr float kBackground[3] = {0.80f, 0.82f, 0.85f};

/// A framebuffer of `extent` for `pass` over `views` (in the pass's attachment order).
VkFramebuffer create_framebuffer(const VulkanContext& context, VkRenderPass pass, std::span<const VkImageView> views, VkExtent2D extent);

/// Begins a scene pass on `framebuffer`, clearing colour to kBackground and depth to 1 (a
/// NextSlice pass ignores the clear values).
void begin_scene_pass(VkCommandBuffer commands, VkRenderPass pass, VkFramebuffer framebuffer, VkExtent2D extent);

/// RGBA, 8 bits per channel, rows top to bottom.
struct Pixels {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgba;
};

/// A picture rendered into host memory: the scene pass into an image, then copied back.
class OffscreenTarget {
 public:
  /// A target of width × height pixels with `samples` (reduced to what the device supports).
  OffscreenTarget(const VulkanContext& context, uint32_t width, uint32_t height, int samples);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;

  /// The render pass its frames use.
  VkRenderPass render_pass() const { return render_pass_; }
  /// Its formats and sample count.
  const PassFormat& format() const { return format_; }
  /// Its size in pixels.
  VkExtent2D extent() const { return extent_; }

  /// Begins the scene pass (recording into `commands`).
  void begin(VkCommandBuffer commands);
  /// Ends the pass and copies the image into host memory; pixels() is valid once the commands ran.
  void finish(VkCommandBuffer commands);
  /// Ends the pass only (frames that are not read back).
  void end(VkCommandBuffer commands) { vkCmdEndRenderPass(commands); }
  /// The picture, once the commands that finish() recorded have run.
  Pixels pixels() const;

 private:
  void release();

  const VulkanContext& context_;
  PassFormat format_;
  VkExtent2D extent_;
  VkRenderPass render_pass_ = VK_NULL_HANDLE;
  SceneAttachments attachments_;
  Image color_;
  VkFramebuffer framebuffer_ = VK_NULL_HANDLE;
  Buffer readback_;
};

}  // namespace hdeform::engine

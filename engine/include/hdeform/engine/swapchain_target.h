#pragma once
/// @file
/// A window's swapchain as a render target (the window system stays outside: the context owns
/// the surface, and the caller says how big the framebuffer is). One render-finished semaphore
/// per swapchain image, as presentation may hold an image longer than a frame slot.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "hdeform/engine/render_targets.h"

namespace hdeform::engine {

/// A window's swapchain as a target, rebuilt when the window's size changes. A frame is two passes:
/// the scene pass into an image of its own, which a frame may skip when the scene has not changed
/// (on a CPU device a frame of a scan of millions of triangles takes seconds, where the panel
/// around it changes with every mouse move), then the scene copied into the swapchain image and
/// the overlay pass (the user interface) drawn over it. Presentation optionally on a thread of its
/// own.
class SwapchainTarget {
 public:
  // `framebuffer_size` returns the window's framebuffer size in pixels (0×0 while minimised).
  // With `present_on_thread`, present() hands the image to a thread of its own and returns: a
  // software presentation engine (lavapipe on X11) blocks in vkQueuePresentKHR until the frame
  // is rendered and copied, a frame's time in which the caller could not take input.
  /// Creates the swapchain for the context's surface.
  SwapchainTarget(const VulkanContext& context, std::function<VkExtent2D()> framebuffer_size, int samples, bool vsync,
                  bool present_on_thread = false);
  ~SwapchainTarget();
  SwapchainTarget(const SwapchainTarget&) = delete;
  SwapchainTarget& operator=(const SwapchainTarget&) = delete;

  /// The scene pass, for the pipelines that draw the scene.
  VkRenderPass render_pass() const { return render_pass_; }
  /// The overlay pass (single-sampled colour, no depth, the scene loaded), for the user interface.
  VkRenderPass overlay_pass() const { return overlay_pass_; }
  /// Its formats and sample count.
  const PassFormat& format() const { return format_; }
  /// The swapchain's size in pixels (0×0 while minimised).
  VkExtent2D extent() const { return extent_; }
  /// Whether the window is minimised (nothing to draw into).
  bool minimised() const { return extent_.width == 0 || extent_.height == 0; }

  /// Acquires the next image, signalling `image_available`. Returns false when there is nothing
  /// to draw into this time (minimised, or the swapchain was just rebuilt for a new size).
  bool acquire(VkSemaphore image_available, uint32_t& image);
  /// Begins the scene pass into the scene image (cleared).
  void begin_scene(VkCommandBuffer commands);
  /// Ends the scene pass; from here the scene image holds a scene of the current size.
  void end_scene(VkCommandBuffer commands);
  /// Whether the scene image holds a whole scene of the current size, drawn since the swapchain was
  /// last built: a frame whose scene has not changed may skip its scene pass.
  bool scene_kept() const { return scene_kept_; }
  /// Copies the scene image into image `image` and begins the overlay pass on it. Needs a scene:
  /// scene_kept(), or a scene pass recorded before in this frame.
  void begin(VkCommandBuffer commands, uint32_t image);
  /// Ends the overlay pass; with `keep_copy` also copies the image for read_last_image().
  void end(VkCommandBuffer commands, uint32_t image, bool keep_copy = false);
  /// The semaphore a frame into `image` signals when rendered, which present() waits on.
  VkSemaphore render_finished(uint32_t image) const { return images_[image].render_finished; }
  /// Presents (waiting on render_finished); rebuilds the swapchain when it is out of date.
  void present(uint32_t image);
  /// Rebuilds for the current framebuffer size (after a resize event).
  void rebuild();
  /// The last image ended with keep_copy, once its frame has finished (RGBA).
  Pixels read_last_image();

 private:
  struct SwapImage {
    VkImage image = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
    VkFramebuffer overlay_framebuffer = VK_NULL_HANDLE;
    VkSemaphore render_finished = VK_NULL_HANDLE;
  };
  void create_swapchain();
  void destroy_swapchain();
  void present_now(uint32_t image);
  void wait_for_presenter();
  void rethrow_present_error(std::unique_lock<std::mutex>& locked);  ///< with present_mutex_ held

  const VulkanContext& context_;
  std::function<VkExtent2D()> framebuffer_size_;
  bool vsync_;
  PassFormat format_;
  VkColorSpaceKHR color_space_ = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
  VkRenderPass render_pass_ = VK_NULL_HANDLE;
  VkRenderPass overlay_pass_ = VK_NULL_HANDLE;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkExtent2D extent_{0, 0};
  std::vector<SwapImage> images_;
  SceneAttachments attachments_;
  Image scene_;  ///< the scene pass's single-sampled colour, copied into each frame's image
  VkFramebuffer scene_framebuffer_ = VK_NULL_HANDLE;
  bool scene_kept_ = false;
  Buffer copy_;
  VkExtent2D copy_extent_{0, 0};

  std::thread presenter_;
  /// vkAcquireNextImageKHR and vkQueuePresentKHR both need the swapchain to themselves.
  std::mutex swapchain_mutex_;
  std::mutex present_mutex_;
  std::condition_variable present_signal_;
  std::deque<uint32_t> to_present_;
  bool presenting_ = false;
  bool stopping_ = false;
  std::atomic<bool> out_of_date_{false};
  std::exception_ptr present_error_;  ///< a failed present on the thread, rethrown on the caller's
};

}  // namespace hdeform::engine

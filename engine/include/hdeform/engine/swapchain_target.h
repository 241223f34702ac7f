#pragma once
/// @file
/// A window's swapchain as a render target (the window system stays outside: the context owns
/// the surface, and the caller says how big the framebuffer is). One render-finished semaphore
/// per swapchain image, as presentation may hold an image longer than a frame slot.
#include <array>
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
///
/// A picture of the scene may also be built in slices over several frames (single-sampled targets):
/// each frame draws a part of the triangles into a second image, over what the slices before it
/// drew, while the frames show the last picture completed; the last slice makes the new picture
/// the one shown. So the window keeps answering while a CPU device draws a scan.
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
  /// Whether a picture may be built in slices (begin_scene with slices > 1): single-sampled only.
  bool slices_supported() const { return next_slice_pass_ != VK_NULL_HANDLE; }
  /// Begins slice `slice` of `slices` of a scene pass into the picture being built: slice 0 clears
  /// it and starts a new picture (dropping one left unfinished); a later slice must be the one
  /// scene_build() names, and draws over what the slices before it drew.
  void begin_scene(VkCommandBuffer commands, int slice = 0, int slices = 1);
  /// Ends the slice. After the last one the picture built is the one the frames show.
  void end_scene(VkCommandBuffer commands);
  /// Whether a whole picture of the current size, drawn since the swapchain was last built, is
  /// shown: a frame whose scene has not changed may skip its scene pass.
  bool scene_kept() const { return shown_ >= 0; }
  /// A picture being built: the slice it needs next, of how many.
  struct SceneBuild {
    int next = 0;
    int slices = 0;
    bool operator==(const SceneBuild&) const = default;
  };
  /// The picture being built; {0, 0} when none is (none was started, the last was completed, or
  /// the swapchain was rebuilt since: a new size needs a new picture).
  SceneBuild scene_build() const { return build_; }
  /// Forgets the picture shown (a new mesh: the last one's picture does not stand for it), and any
  /// being built: the frames show the background until the next picture is complete.
  void drop_scene() {
    shown_ = -1;
    build_ = {};
  }
  /// Copies the picture shown into image `image` (the background where none is yet, while the
  /// first one is built) and begins the overlay pass on it.
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
  VkRenderPass first_slice_pass_ = VK_NULL_HANDLE;  ///< null when multisampled (no slices)
  VkRenderPass next_slice_pass_ = VK_NULL_HANDLE;
  SceneAttachments attachments_;
  /// The scene passes' single-sampled colour: the picture shown, copied into each frame's image,
  /// and the one being built.
  std::array<Image, 2> scenes_;
  std::array<VkFramebuffer, 2> scene_framebuffers_{};
  int shown_ = -1;  ///< the scene image shown; -1: none yet at this size
  int drawing_ = 0;  ///< the one the next scene pass draws into
  SceneBuild build_;
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

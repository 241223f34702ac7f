#include "hdeform/engine/swapchain_target.h"

#include "hdeform/trace.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>

namespace hdeform::engine {
namespace {

VkSurfaceFormatKHR choose_surface_format(const VulkanContext& context) {
  uint32_t count = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(context.physical_device(), context.surface(), &count, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(count);
  vkGetPhysicalDeviceSurfaceFormatsKHR(context.physical_device(), context.surface(), &count, formats.data());
  if (formats.empty()) throw RenderError("the window surface offers no image format");
  // UNORM like the offscreen target, so that a window and a PNG of the same view agree.
  for (const VkFormat wanted : {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM}) {
    for (const auto& format : formats) {
      if (format.format == wanted && format.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) return format;
    }
  }
  return formats.front();
}

VkPresentModeKHR choose_present_mode(const VulkanContext& context, bool vsync) {
  if (vsync) return VK_PRESENT_MODE_FIFO_KHR;
  uint32_t count = 0;
  vkGetPhysicalDeviceSurfacePresentModesKHR(context.physical_device(), context.surface(), &count, nullptr);
  std::vector<VkPresentModeKHR> modes(count);
  vkGetPhysicalDeviceSurfacePresentModesKHR(context.physical_device(), context.surface(), &count, modes.data());
  for (const VkPresentModeKHR wanted : {VK_PRESENT_MODE_MAILBOX_KHR, VK_PRESENT_MODE_IMMEDIATE_KHR}) {
    if (std::find(modes.begin(), modes.end(), wanted) != modes.end()) return wanted;
  }
  return VK_PRESENT_MODE_FIFO_KHR;
}

// A barrier that moves a colour image from one layout to another.
VkImageMemoryBarrier color_layout_barrier(VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src_access, VkAccessFlags dst_access) {
  VkImageMemoryBarrier barrier{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  barrier.srcAccessMask = src_access;
  barrier.dstAccessMask = dst_access;
  barrier.oldLayout = from;
  barrier.newLayout = to;
  barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.image = image;
  barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  return barrier;
}

}  // namespace

SwapchainTarget::SwapchainTarget(const VulkanContext& context, std::function<VkExtent2D()> framebuffer_size, int samples, bool vsync,
                                 bool present_on_thread)
    : context_(context), framebuffer_size_(std::move(framebuffer_size)), vsync_(vsync) {
  if (context.surface() == VK_NULL_HANDLE) throw RenderError("a swapchain needs a context created with a window surface");
  const VkSurfaceFormatKHR surface_format = choose_surface_format(context);
  format_.color = surface_format.format;
  color_space_ = surface_format.colorSpace;
  format_.depth = choose_depth_format(context);
  format_.samples = context.supported_samples(samples);
  render_pass_ = create_scene_render_pass(context, format_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  if (format_.samples == VK_SAMPLE_COUNT_1_BIT) {
    first_slice_pass_ = create_scene_render_pass(context, format_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, ScenePass::FirstSlice);
    next_slice_pass_ = create_scene_render_pass(context, format_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, ScenePass::NextSlice);
  }
  overlay_pass_ = create_overlay_render_pass(context, format_.color);
  create_swapchain();
  if (present_on_thread) {
    presenter_ = std::thread([this] {
      trace::name_thread("presenter");
      std::unique_lock lock(present_mutex_);
      for (;;) {
        present_signal_.wait(lock, [this] { return stopping_ || !to_present_.empty(); });
        if (to_present_.empty()) return;
        const uint32_t image = to_present_.front();
        to_present_.pop_front();
        presenting_ = true;
        lock.unlock();
        std::exception_ptr error;
        try {
          present_now(image);
        } catch (...) {
          error = std::current_exception();
        }
        lock.lock();
        if (error && !present_error_) present_error_ = error;
        presenting_ = false;
        present_signal_.notify_all();
      }
    });
  }
}

SwapchainTarget::~SwapchainTarget() {
  if (presenter_.joinable()) {
    try {
      wait_for_presenter();
    } catch (const std::exception&) {
      // Already reported to the caller of the failed frame, or the device is gone: close anyway.
    }
    {
      std::lock_guard lock(present_mutex_);
      stopping_ = true;
    }
    present_signal_.notify_all();
    presenter_.join();
  }
  vkDeviceWaitIdle(context_.device());
  destroy_swapchain();
  context_.destroy(copy_);
  for (const VkRenderPass pass : {render_pass_, first_slice_pass_, next_slice_pass_, overlay_pass_}) {
    if (pass != VK_NULL_HANDLE) vkDestroyRenderPass(context_.device(), pass, nullptr);
  }
}

void SwapchainTarget::create_swapchain() {
  const VkDevice device = context_.device();
  VkSurfaceCapabilitiesKHR capabilities;
  check(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(context_.physical_device(), context_.surface(), &capabilities),
        "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
  VkExtent2D wanted = framebuffer_size_();
  if (capabilities.currentExtent.width != UINT32_MAX) wanted = capabilities.currentExtent;
  extent_ = {std::clamp(wanted.width, capabilities.minImageExtent.width, capabilities.maxImageExtent.width),
             std::clamp(wanted.height, capabilities.minImageExtent.height, capabilities.maxImageExtent.height)};
  if (wanted.width == 0 || wanted.height == 0) {
    extent_ = {0, 0};  // minimised: no swapchain until the window comes back
    return;
  }
  uint32_t image_count = capabilities.minImageCount + 1;
  if (capabilities.maxImageCount > 0) image_count = std::min(image_count, capabilities.maxImageCount);
  VkSwapchainCreateInfoKHR info{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  info.surface = context_.surface();
  info.minImageCount = image_count;
  info.imageFormat = format_.color;
  info.imageColorSpace = color_space_;
  info.imageExtent = extent_;
  info.imageArrayLayers = 1;
  if (!(capabilities.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) {
    throw RenderError("the window's images cannot be copied into (no VK_IMAGE_USAGE_TRANSFER_DST_BIT), which drawing the scene "
                      "once for several frames needs; hdeform render still makes pictures");
  }
  info.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  if (capabilities.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) info.imageUsage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.preTransform = capabilities.currentTransform;
  info.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  info.presentMode = choose_present_mode(context_, vsync_);
  info.clipped = VK_TRUE;
  check(vkCreateSwapchainKHR(device, &info, nullptr, &swapchain_), "vkCreateSwapchainKHR");

  uint32_t count = 0;
  vkGetSwapchainImagesKHR(device, swapchain_, &count, nullptr);
  std::vector<VkImage> images(count);
  vkGetSwapchainImagesKHR(device, swapchain_, &count, images.data());
  attachments_.create(context_, format_, extent_);
  for (std::size_t k = 0; k < scenes_.size(); ++k) {
    scenes_[k] = context_.create_image(extent_.width, extent_.height, format_.color,
                                       VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, VK_SAMPLE_COUNT_1_BIT,
                                       VK_IMAGE_ASPECT_COLOR_BIT);
    scene_framebuffers_[k] = create_framebuffer(context_, render_pass_, attachments_.views(format_, scenes_[k].view), extent_);
  }
  shown_ = -1;
  drawing_ = 0;
  build_ = {};
  images_.resize(count);
  for (uint32_t i = 0; i < count; ++i) {
    SwapImage& swap_image = images_[i];
    swap_image.image = images[i];
    VkImageViewCreateInfo view{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    view.image = images[i];
    view.viewType = VK_IMAGE_VIEW_TYPE_2D;
    view.format = format_.color;
    view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    check(vkCreateImageView(device, &view, nullptr, &swap_image.view), "vkCreateImageView");
    swap_image.overlay_framebuffer = create_framebuffer(context_, overlay_pass_, std::span(&swap_image.view, 1), extent_);
    VkSemaphoreCreateInfo semaphore{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    check(vkCreateSemaphore(device, &semaphore, nullptr, &swap_image.render_finished), "vkCreateSemaphore");
  }
}

void SwapchainTarget::destroy_swapchain() {
  const VkDevice device = context_.device();
  for (SwapImage& swap_image : images_) {
    vkDestroySemaphore(device, swap_image.render_finished, nullptr);
    vkDestroyFramebuffer(device, swap_image.overlay_framebuffer, nullptr);
    vkDestroyImageView(device, swap_image.view, nullptr);
  }
  images_.clear();
  for (std::size_t k = 0; k < scenes_.size(); ++k) {
    if (scene_framebuffers_[k] != VK_NULL_HANDLE) vkDestroyFramebuffer(device, scene_framebuffers_[k], nullptr);
    scene_framebuffers_[k] = VK_NULL_HANDLE;
    context_.destroy(scenes_[k]);
  }
  shown_ = -1;
  build_ = {};
  attachments_.destroy(context_);
  if (swapchain_ != VK_NULL_HANDLE) vkDestroySwapchainKHR(device, swapchain_, nullptr);
  swapchain_ = VK_NULL_HANDLE;
}

void SwapchainTarget::wait_for_presenter() {
  if (!presenter_.joinable()) return;
  std::unique_lock lock(present_mutex_);
  present_signal_.wait(lock, [this] { return to_present_.empty() && !presenting_; });
  rethrow_present_error(lock);
}

void SwapchainTarget::rethrow_present_error(std::unique_lock<std::mutex>& locked) {
  (void)locked;
  if (!present_error_) return;
  std::exception_ptr error;
  std::swap(error, present_error_);
  std::rethrow_exception(error);
}

void SwapchainTarget::rebuild() {
  wait_for_presenter();
  out_of_date_ = false;
  vkDeviceWaitIdle(context_.device());
  destroy_swapchain();
  create_swapchain();
}

bool SwapchainTarget::acquire(VkSemaphore image_available, uint32_t& image) {
  // Not every presentation engine reports a resized window as out of date (lavapipe on X11
  // does not), so the size is compared here.
  const VkExtent2D size = framebuffer_size_();
  if (size.width == 0 || size.height == 0) return false;
  if (swapchain_ == VK_NULL_HANDLE || out_of_date_ || size.width != extent_.width || size.height != extent_.height) {
    rebuild();
    if (swapchain_ == VK_NULL_HANDLE) return false;
  }
  VkResult result;
  if (!presenter_.joinable()) {
    result = vkAcquireNextImageKHR(context_.device(), swapchain_, UINT64_MAX, image_available, VK_NULL_HANDLE, &image);
  } else {
    // The presenting thread may hold the image this call would wait for, and it needs the
    // swapchain to release it: ask without waiting, and let it present in between.
    for (;;) {
      {
        std::lock_guard lock(swapchain_mutex_);
        result = vkAcquireNextImageKHR(context_.device(), swapchain_, 0, image_available, VK_NULL_HANDLE, &image);
      }
      if (result != VK_NOT_READY && result != VK_TIMEOUT) break;
      std::unique_lock lock(present_mutex_);
      rethrow_present_error(lock);
      present_signal_.wait_for(lock, std::chrono::milliseconds(1));
    }
  }
  if (result == VK_ERROR_OUT_OF_DATE_KHR) {
    rebuild();
    return false;
  }
  if (result != VK_SUBOPTIMAL_KHR) check(result, "vkAcquireNextImageKHR");
  return true;
}

void SwapchainTarget::begin_scene(VkCommandBuffer commands, int slice, int slices) {
  if (slices < 1 || slice < 0 || slice >= slices || (slices > 1 && !slices_supported())) {
    throw std::logic_error("SwapchainTarget::begin_scene: slice " + std::to_string(slice) + " of " + std::to_string(slices));
  }
  if (slice > 0 && build_ != SceneBuild{slice, slices}) throw std::logic_error("SwapchainTarget::begin_scene: not the slice the picture needs next");
  // A new picture goes into the image not shown (an unfinished one there is dropped).
  if (slice == 0) drawing_ = shown_ == 0 ? 1 : 0;
  const VkRenderPass pass = slices == 1 ? render_pass_ : slice == 0 ? first_slice_pass_ : next_slice_pass_;
  begin_scene_pass(commands, pass, scene_framebuffers_[static_cast<std::size_t>(drawing_)], extent_);
  build_ = {slice + 1, slices};
}

void SwapchainTarget::end_scene(VkCommandBuffer commands) {
  vkCmdEndRenderPass(commands);
  if (build_.next < build_.slices) return;
  shown_ = drawing_;
  build_ = {};
}

void SwapchainTarget::begin(VkCommandBuffer commands, uint32_t image) {
  // The image, once presentation let go of it (the acquire semaphore's wait is at this stage),
  // receives the scene; the scene pass left the scene image ready to be read by a copy.
  const VkImageMemoryBarrier barrier = color_layout_barrier(images_[image].image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0,
                                                           VK_ACCESS_TRANSFER_WRITE_BIT);
  vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 1,
                       &barrier);
  if (shown_ >= 0) {
    VkImageCopy region{};
    region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.dstSubresource = region.srcSubresource;
    region.extent = {extent_.width, extent_.height, 1};
    vkCmdCopyImage(commands, scenes_[static_cast<std::size_t>(shown_)].image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, images_[image].image,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  } else {
    const VkClearColorValue background{{kBackground[0], kBackground[1], kBackground[2], 1.0f}};
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(commands, images_[image].image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &background, 1, &range);
  }
  VkRenderPassBeginInfo begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  begin.renderPass = overlay_pass_;
  begin.framebuffer = images_[image].overlay_framebuffer;
  begin.renderArea = {{0, 0}, extent_};
  vkCmdBeginRenderPass(commands, &begin, VK_SUBPASS_CONTENTS_INLINE);
}

void SwapchainTarget::end(VkCommandBuffer commands, uint32_t image, bool keep_copy) {
  vkCmdEndRenderPass(commands);
  if (!keep_copy) return;
  const VkDeviceSize bytes = VkDeviceSize{extent_.width} * extent_.height * 4;
  if (copy_.size < bytes) {
    context_.destroy(copy_);  // the caller waited for the frames that used it
    copy_ = context_.create_buffer(bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  }
  copy_extent_ = extent_;
  VkImageMemoryBarrier barrier = color_layout_barrier(images_[image].image, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                                     VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT);
  vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr,
                       1, &barrier);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {extent_.width, extent_.height, 1};
  vkCmdCopyImageToBuffer(commands, images_[image].image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, copy_.buffer, 1, &region);
  barrier.srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  barrier.dstAccessMask = 0;
  barrier.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  barrier.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  VkMemoryBarrier host{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &host,
                       0, nullptr, 1, &barrier);
}

void SwapchainTarget::present(uint32_t image) {
  if (!presenter_.joinable()) {
    present_now(image);
    if (out_of_date_) rebuild();
    return;
  }
  {
    std::unique_lock lock(present_mutex_);
    rethrow_present_error(lock);
    to_present_.push_back(image);
  }
  present_signal_.notify_all();
}

void SwapchainTarget::present_now(uint32_t image) {
  const VkSemaphore wait = images_[image].render_finished;
  VkPresentInfoKHR info{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
  info.waitSemaphoreCount = 1;
  info.pWaitSemaphores = &wait;
  info.swapchainCount = 1;
  info.pSwapchains = &swapchain_;
  info.pImageIndices = &image;
  VkResult result;
  {
    std::scoped_lock lock(swapchain_mutex_, context_.queue_mutex());
    const trace::Scope traced("present", "frame");
    result = vkQueuePresentKHR(context_.queue(), &info);
  }
  if (result == VK_ERROR_OUT_OF_DATE_KHR || result == VK_SUBOPTIMAL_KHR) {
    out_of_date_ = true;  // rebuilt at the next acquire, on the rendering thread
    return;
  }
  check(result, "vkQueuePresentKHR");
}

Pixels SwapchainTarget::read_last_image() {
  wait_for_presenter();
  Pixels pixels{copy_extent_.width, copy_extent_.height, std::vector<uint8_t>(std::size_t{copy_extent_.width} * copy_extent_.height * 4)};
  if (pixels.rgba.empty()) return pixels;
  std::memcpy(pixels.rgba.data(), copy_.mapped, pixels.rgba.size());
  if (format_.color == VK_FORMAT_B8G8R8A8_UNORM) {
    for (std::size_t i = 0; i < pixels.rgba.size(); i += 4) std::swap(pixels.rgba[i], pixels.rgba[i + 2]);
  }
  return pixels;
}

}  // namespace hdeform::engine

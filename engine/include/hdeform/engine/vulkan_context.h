#pragma once
/// @file
/// The Vulkan instance, the chosen device and its graphics queue, plus the small helpers every
/// part of the engine needs (buffers, images, one-off command submission). Plain structs with
/// create/destroy pairs; the context owns only what it creates.
#include <vulkan/vulkan.h>

#include <atomic>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace hdeform::engine {

/// Rendering could not start or failed (no device, out of memory, device lost). The message says
/// what to do where it can.
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws RenderError naming the call when a Vulkan call fails.
void check(VkResult result, const char* what);

/// How a VulkanContext chooses its device and what it enables.
struct ContextOptions {
  /// Which device: empty for automatic (discrete GPU, then integrated, virtual, then a CPU device
  /// such as lavapipe), "gpu", "cpu", a device index, or part of a device's name. When empty,
  /// the environment variable HDEFORM_VULKAN_DEVICE is used.
  std::string device;
  /// Khronos validation layer, messages counted; also enabled by HDEFORM_VALIDATION=1.
  bool validation = false;
  /// Instance extensions a window system needs (from GLFW).
  std::vector<std::string> instance_extensions;
  /// Creates the window surface once the instance exists; the chosen device must present to it.
  std::function<VkSurfaceKHR(VkInstance)> create_surface;
  /// Print the chosen device on stderr.
  bool announce = true;
};

/// A buffer and its memory.
struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  ///< host-visible buffers stay mapped
};

/// An image, its memory and its view.
struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
};

/// The Vulkan instance, the chosen device, its queue and command pool, and helpers for buffers,
/// images and one-off submissions; validation messages counted when the layer is on.
class VulkanContext {
 public:
  /// Chooses a device and creates everything. Throws RenderError naming what is missing (no device,
  /// no match for ContextOptions::device, no validation layer).
  explicit VulkanContext(const ContextOptions& options = {});
  ~VulkanContext();
  VulkanContext(const VulkanContext&) = delete;
  VulkanContext& operator=(const VulkanContext&) = delete;

  /// The Vulkan instance.
  VkInstance instance() const { return instance_; }
  /// The chosen physical device.
  VkPhysicalDevice physical_device() const { return physical_device_; }
  /// The logical device.
  VkDevice device() const { return device_; }
  /// The graphics (and present) queue; submit under queue_mutex().
  VkQueue queue() const { return queue_; }
  /// The queue's family index.
  uint32_t queue_family() const { return queue_family_; }
  /// The command pool, for the thread that renders.
  VkCommandPool command_pool() const { return command_pool_; }  // for the thread that renders
  /// Held around every submission and presentation: a queue must not be used from two threads at
  /// once, and the swapchain may present from its own thread.
  std::mutex& queue_mutex() const { return queue_mutex_; }
  /// The window surface, or VK_NULL_HANDLE offscreen.
  VkSurfaceKHR surface() const { return surface_; }
  /// The chosen device's properties.
  const VkPhysicalDeviceProperties& properties() const { return properties_; }
  /// The chosen device's name.
  std::string device_name() const { return properties_.deviceName; }
  /// Whether the device is a CPU rasterizer (lavapipe).
  bool is_cpu_device() const { return properties_.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU; }
  /// Whether the validation layer is on.
  bool validation_enabled() const { return messenger_ != VK_NULL_HANDLE; }
  /// Whether the device has timeline semaphores (completion times need them).
  bool has_timeline_semaphores() const { return timeline_semaphores_; }

  /// Validation messages of severity warning or error since creation (0 without validation).
  std::size_t validation_message_count() const { return validation_messages_.load(); }
  /// The validation messages' texts.
  std::vector<std::string> validation_messages() const;

  /// The largest sample count ≤ wanted that colour and depth attachments both support.
  VkSampleCountFlagBits supported_samples(int wanted) const;
  /// Multisampling for interactive frames: 4 on a GPU; 1 on a CPU device, where lavapipe's 4×
  /// measured 3.3 times the frame time (pictures written to files keep 4×).
  int interactive_samples() const { return is_cpu_device() ? 1 : 4; }

  Buffer create_buffer(VkDeviceSize size, VkBufferUsageFlags usage) const;  ///< host-visible, coherent, mapped
  /// Frees a buffer made by create_buffer (a no-op for an empty one).
  void destroy(Buffer& buffer) const;
  /// An image of that size, format, usage and sample count, with memory and a view of `aspect`.
  Image create_image(uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage, VkSampleCountFlagBits samples,
                     VkImageAspectFlags aspect) const;
  /// Frees an image made by create_image (a no-op for an empty one).
  void destroy(Image& image) const;

  /// Records with `record`, submits, waits.
  void submit_and_wait(const std::function<void(VkCommandBuffer)>& record) const;

 private:
  friend VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT, VkDebugUtilsMessageTypeFlagsEXT,
                                                   const VkDebugUtilsMessengerCallbackDataEXT*, void*);
  void record_validation_message(const char* message);
  uint32_t memory_type(uint32_t allowed, VkMemoryPropertyFlags properties) const;
  void choose_device(const std::string& preference, bool announce);
  void release();

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_device_ = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties properties_{};
  VkPhysicalDeviceMemoryProperties memory_properties_{};
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  bool timeline_semaphores_ = false;
  VkCommandPool command_pool_ = VK_NULL_HANDLE;
  mutable std::mutex queue_mutex_;
  mutable std::mutex messages_mutex_;
  std::vector<std::string> messages_;
  std::atomic<std::size_t> validation_messages_{0};
};

}  // namespace hdeform::engine

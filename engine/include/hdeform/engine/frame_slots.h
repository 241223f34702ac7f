#pragma once
/// @file
/// Frames in flight: each slot has its own command buffer, fence and image-available semaphore.
/// A slot is reused only after its fence says the GPU finished with it, so the CPU can prepare the
/// next frame while the previous one renders.
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "hdeform/engine/vulkan_context.h"

namespace hdeform::engine {

/// Frames the CPU may record while the device still renders earlier ones.
inline constexpr uint32_t kFramesInFlight = 2;

/// Frames in flight: per slot a command buffer, a fence and an image-available semaphore, used
/// round robin, with optional completion times and device timestamps per frame.
class FrameSlots {
 public:
  /// One frame's resources.
  struct Slot {
    uint32_t index = 0;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkSemaphore image_available = VK_NULL_HANDLE;
    std::uint64_t frame = 0;  ///< the last frame submitted from this slot
  };

  /// Creates `count` slots on the context's command pool.
  FrameSlots(const VulkanContext& context, uint32_t count = kFramesInFlight);
  ~FrameSlots();
  FrameSlots(const FrameSlots&) = delete;
  FrameSlots& operator=(const FrameSlots&) = delete;

  /// The number of slots.
  uint32_t count() const { return static_cast<uint32_t>(slots_.size()); }
  /// The next slot, round robin, once the GPU has finished its previous frame; recording begun.
  Slot& begin();
  /// Whether the next slot's previous frame has finished, waiting at most `timeout`.
  bool next_ready(std::chrono::nanoseconds timeout);
  /// Ends recording and submits; waits on `wait` (at colour output) and signals `signal` if given.
  /// Returns the frame's number (1, 2, ...), which the completion timer reports back.
  std::uint64_t submit(Slot& slot, VkSemaphore wait = VK_NULL_HANDLE, VkSemaphore signal = VK_NULL_HANDLE);
  /// Waits until every slot's frame has finished.
  void wait_all();

  /// When each submitted frame finished on the device (needs timeline semaphores; a thread waits on
  /// the frame numbers in turn), for figures such as input-to-screen latency.
  struct Completion {
    std::uint64_t frame;
    std::chrono::steady_clock::time_point time;
  };
  /// Starts the thread that records when each submitted frame finishes (timeline semaphores).
  void enable_completion_times();
  /// The completions recorded since the last call, oldest first.
  std::vector<Completion> take_completions();

  /// The device's own time for each finished frame (timestamp queries at the start and end of its
  /// commands), where the device has timestamps; also in the trace, on a "device" track, ending
  /// when the frame was seen finished. Frames in finishing order.
  struct DeviceTime {
    std::uint64_t frame;
    double milliseconds;
  };
  /// Whether the device reports its own time per frame.
  bool has_device_times() const { return queries_ != VK_NULL_HANDLE; }
  /// The device times recorded since the last call, in finishing order.
  std::vector<DeviceTime> take_device_times();

 private:
  const VulkanContext& context_;
  std::vector<Slot> slots_;
  uint32_t next_ = 0;
  std::uint64_t submitted_ = 0;
  VkSemaphore timeline_ = VK_NULL_HANDLE;
  std::thread watcher_;
  std::mutex completions_mutex_;
  std::condition_variable submitted_signal_;
  std::vector<Completion> completions_;
  bool stopping_ = false;
  VkQueryPool queries_ = VK_NULL_HANDLE;  ///< two timestamps per slot
  double timestamp_ns_ = 0.0;             ///< nanoseconds per timestamp tick
  std::vector<DeviceTime> device_times_;  ///< render thread only
  void read_device_time(const Slot& slot);
};

}  // namespace hdeform::engine

#pragma once
// Frames in flight: each slot has its own command buffer, fence and image-available semaphore.
// A slot is reused only after its fence says the GPU finished with it, so the CPU can prepare the
// next frame while the previous one renders.
#include <vector>

#include "hdeform/engine/vulkan_context.h"

namespace hdeform::engine {

inline constexpr uint32_t kFramesInFlight = 2;

class FrameSlots {
 public:
  struct Slot {
    uint32_t index = 0;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkSemaphore image_available = VK_NULL_HANDLE;
  };

  FrameSlots(const VulkanContext& context, uint32_t count = kFramesInFlight);
  ~FrameSlots();
  FrameSlots(const FrameSlots&) = delete;
  FrameSlots& operator=(const FrameSlots&) = delete;

  uint32_t count() const { return static_cast<uint32_t>(slots_.size()); }
  // The next slot, round robin, once the GPU has finished its previous frame; recording begun.
  Slot& begin();
  // Ends recording and submits; waits on `wait` (at colour output) and signals `signal` if given.
  void submit(Slot& slot, VkSemaphore wait = VK_NULL_HANDLE, VkSemaphore signal = VK_NULL_HANDLE);
  // Waits until every slot's frame has finished.
  void wait_all();

 private:
  const VulkanContext& context_;
  std::vector<Slot> slots_;
  uint32_t next_ = 0;
};

}  // namespace hdeform::engine

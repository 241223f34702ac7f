#include "hdeform/engine/frame_slots.h"

namespace hdeform::engine {

FrameSlots::FrameSlots(const VulkanContext& context, uint32_t count) : context_(context), slots_(count) {
  const VkDevice device = context.device();
  for (uint32_t i = 0; i < count; ++i) {
    Slot& slot = slots_[i];
    slot.index = i;
    VkCommandBufferAllocateInfo allocation{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    allocation.commandPool = context.command_pool();
    allocation.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocation.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(device, &allocation, &slot.commands), "vkAllocateCommandBuffers");
    VkFenceCreateInfo fence{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    fence.flags = VK_FENCE_CREATE_SIGNALED_BIT;  // the first wait returns at once
    check(vkCreateFence(device, &fence, nullptr, &slot.fence), "vkCreateFence");
    VkSemaphoreCreateInfo semaphore{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    check(vkCreateSemaphore(device, &semaphore, nullptr, &slot.image_available), "vkCreateSemaphore");
  }
}

FrameSlots::~FrameSlots() {
  const VkDevice device = context_.device();
  vkDeviceWaitIdle(device);
  for (Slot& slot : slots_) {
    vkDestroySemaphore(device, slot.image_available, nullptr);
    vkDestroyFence(device, slot.fence, nullptr);
    vkFreeCommandBuffers(device, context_.command_pool(), 1, &slot.commands);
  }
}

FrameSlots::Slot& FrameSlots::begin() {
  Slot& slot = slots_[next_];
  next_ = (next_ + 1) % count();
  check(vkWaitForFences(context_.device(), 1, &slot.fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  check(vkResetCommandBuffer(slot.commands, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(slot.commands, &begin), "vkBeginCommandBuffer");
  return slot;
}

void FrameSlots::submit(Slot& slot, VkSemaphore wait, VkSemaphore signal) {
  check(vkEndCommandBuffer(slot.commands), "vkEndCommandBuffer");
  check(vkResetFences(context_.device(), 1, &slot.fence), "vkResetFences");
  const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.waitSemaphoreCount = wait != VK_NULL_HANDLE ? 1 : 0;
  submit.pWaitSemaphores = &wait;
  submit.pWaitDstStageMask = &wait_stage;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &slot.commands;
  submit.signalSemaphoreCount = signal != VK_NULL_HANDLE ? 1 : 0;
  submit.pSignalSemaphores = &signal;
  check(vkQueueSubmit(context_.queue(), 1, &submit, slot.fence), "vkQueueSubmit");
}

void FrameSlots::wait_all() {
  std::vector<VkFence> fences;
  for (const Slot& slot : slots_) fences.push_back(slot.fence);
  check(vkWaitForFences(context_.device(), static_cast<uint32_t>(fences.size()), fences.data(), VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

}  // namespace hdeform::engine

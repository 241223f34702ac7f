#include "hdeform/engine/frame_slots.h"

#include <array>

#include "hdeform/trace.h"

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
  uint32_t families = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(context.physical_device(), &families, nullptr);
  std::vector<VkQueueFamilyProperties> family(families);
  vkGetPhysicalDeviceQueueFamilyProperties(context.physical_device(), &families, family.data());
  if (context.queue_family() < families && family[context.queue_family()].timestampValidBits > 0 &&
      context.properties().limits.timestampPeriod > 0.0f) {
    VkQueryPoolCreateInfo pool{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    pool.queryType = VK_QUERY_TYPE_TIMESTAMP;
    pool.queryCount = 2 * count;
    check(vkCreateQueryPool(device, &pool, nullptr, &queries_), "vkCreateQueryPool");
    timestamp_ns_ = context.properties().limits.timestampPeriod;
  }
}

FrameSlots::~FrameSlots() {
  const VkDevice device = context_.device();
  vkDeviceWaitIdle(device);
  if (watcher_.joinable()) {
    {
      std::lock_guard lock(completions_mutex_);
      stopping_ = true;
    }
    submitted_signal_.notify_all();
    watcher_.join();
  }
  if (timeline_ != VK_NULL_HANDLE) vkDestroySemaphore(device, timeline_, nullptr);
  if (queries_ != VK_NULL_HANDLE) vkDestroyQueryPool(device, queries_, nullptr);
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
  if (queries_ != VK_NULL_HANDLE && slot.frame > 0) read_device_time(slot);
  check(vkResetCommandBuffer(slot.commands, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(slot.commands, &begin), "vkBeginCommandBuffer");
  if (queries_ != VK_NULL_HANDLE) {
    vkCmdResetQueryPool(slot.commands, queries_, 2 * slot.index, 2);
    vkCmdWriteTimestamp(slot.commands, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries_, 2 * slot.index);
  }
  return slot;
}

void FrameSlots::read_device_time(const Slot& slot) {
  std::array<std::uint64_t, 2> ticks{};
  const VkResult result = vkGetQueryPoolResults(context_.device(), queries_, 2 * slot.index, 2, sizeof ticks, ticks.data(), sizeof(std::uint64_t),
                                                VK_QUERY_RESULT_64_BIT);
  if (result != VK_SUCCESS || ticks[1] < ticks[0]) return;
  const double nanoseconds = static_cast<double>(ticks[1] - ticks[0]) * timestamp_ns_;
  device_times_.push_back({slot.frame, nanoseconds * 1e-6});
  if (device_times_.size() > 1024) device_times_.erase(device_times_.begin());
  // Placed to end when the frame was seen finished: no later than that, exactly that long.
  const std::int64_t end = trace::now_ns();
  trace::complete("device frame", "frame", end - static_cast<std::int64_t>(nanoseconds), end, "device");
}

std::vector<FrameSlots::DeviceTime> FrameSlots::take_device_times() {
  std::vector<DeviceTime> taken;
  taken.swap(device_times_);
  return taken;
}

std::uint64_t FrameSlots::submit(Slot& slot, VkSemaphore wait, VkSemaphore signal) {
  if (queries_ != VK_NULL_HANDLE) vkCmdWriteTimestamp(slot.commands, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, 2 * slot.index + 1);
  check(vkEndCommandBuffer(slot.commands), "vkEndCommandBuffer");
  check(vkResetFences(context_.device(), 1, &slot.fence), "vkResetFences");
  const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  const std::uint64_t frame = submitted_ + 1;
  slot.frame = frame;
  std::vector<VkSemaphore> signals;
  std::vector<std::uint64_t> values;
  if (signal != VK_NULL_HANDLE) {
    signals.push_back(signal);
    values.push_back(0);  // binary: ignored
  }
  if (timeline_ != VK_NULL_HANDLE) {
    signals.push_back(timeline_);
    values.push_back(frame);
  }
  VkTimelineSemaphoreSubmitInfo timeline{VK_STRUCTURE_TYPE_TIMELINE_SEMAPHORE_SUBMIT_INFO};
  timeline.signalSemaphoreValueCount = static_cast<uint32_t>(values.size());
  timeline.pSignalSemaphoreValues = values.data();
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  if (timeline_ != VK_NULL_HANDLE) submit.pNext = &timeline;
  submit.waitSemaphoreCount = wait != VK_NULL_HANDLE ? 1 : 0;
  submit.pWaitSemaphores = &wait;
  submit.pWaitDstStageMask = &wait_stage;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &slot.commands;
  submit.signalSemaphoreCount = static_cast<uint32_t>(signals.size());
  submit.pSignalSemaphores = signals.data();
  {
    std::lock_guard lock(context_.queue_mutex());
    check(vkQueueSubmit(context_.queue(), 1, &submit, slot.fence), "vkQueueSubmit");
  }
  {
    std::lock_guard lock(completions_mutex_);
    submitted_ = frame;
  }
  submitted_signal_.notify_all();
  return frame;
}

void FrameSlots::enable_completion_times() {
  if (timeline_ != VK_NULL_HANDLE || !context_.has_timeline_semaphores()) return;
  VkSemaphoreTypeCreateInfo type{VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO};
  type.semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE;
  type.initialValue = submitted_;
  VkSemaphoreCreateInfo info{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  info.pNext = &type;
  check(vkCreateSemaphore(context_.device(), &info, nullptr, &timeline_), "vkCreateSemaphore");
  const std::uint64_t first = submitted_ + 1;
  watcher_ = std::thread([this, first] {
    for (std::uint64_t frame = first;; ++frame) {
      {
        std::unique_lock lock(completions_mutex_);
        submitted_signal_.wait(lock, [&] { return stopping_ || submitted_ >= frame; });
        if (submitted_ < frame) return;
      }
      VkSemaphoreWaitInfo wait{VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO};
      wait.semaphoreCount = 1;
      wait.pSemaphores = &timeline_;
      wait.pValues = &frame;
      if (vkWaitSemaphores(context_.device(), &wait, UINT64_MAX) != VK_SUCCESS) return;
      std::lock_guard lock(completions_mutex_);
      completions_.push_back({frame, std::chrono::steady_clock::now()});
    }
  });
}

std::vector<FrameSlots::Completion> FrameSlots::take_completions() {
  std::lock_guard lock(completions_mutex_);
  std::vector<Completion> taken;
  taken.swap(completions_);
  return taken;
}

bool FrameSlots::next_ready(std::chrono::nanoseconds timeout) {
  const VkResult result = vkWaitForFences(context_.device(), 1, &slots_[next_].fence, VK_TRUE, static_cast<uint64_t>(timeout.count()));
  if (result == VK_TIMEOUT) return false;
  check(result, "vkWaitForFences");
  return true;
}

void FrameSlots::wait_all() {
  std::vector<VkFence> fences;
  for (const Slot& slot : slots_) fences.push_back(slot.fence);
  check(vkWaitForFences(context_.device(), static_cast<uint32_t>(fences.size()), fences.data(), VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

}  // namespace hdeform::engine

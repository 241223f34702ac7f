#include "hdeform/engine/vulkan_context.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <iostream>

namespace hdeform::engine {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

bool environment_flag(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && std::strcmp(value, "") != 0 && std::strcmp(value, "0") != 0;
}

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

const char* type_name(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
    default: return "other";
  }
}

int preference_rank(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
  }
}

bool has_layer(const char* name) {
  uint32_t count = 0;
  vkEnumerateInstanceLayerProperties(&count, nullptr);
  std::vector<VkLayerProperties> layers(count);
  vkEnumerateInstanceLayerProperties(&count, layers.data());
  return std::any_of(layers.begin(), layers.end(), [&](const VkLayerProperties& layer) { return std::strcmp(layer.layerName, name) == 0; });
}

bool has_device_extension(VkPhysicalDevice device, const char* name) {
  uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(device, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> extensions(count);
  vkEnumerateDeviceExtensionProperties(device, nullptr, &count, extensions.data());
  return std::any_of(extensions.begin(), extensions.end(), [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

}  // namespace

void check(VkResult result, const char* what) {
  if (result == VK_SUCCESS) return;
  if (result == VK_ERROR_DEVICE_LOST) throw RenderError(std::string(what) + ": the Vulkan device was lost");
  if (result == VK_ERROR_OUT_OF_HOST_MEMORY || result == VK_ERROR_OUT_OF_DEVICE_MEMORY) {
    throw RenderError(std::string(what) + ": out of memory");
  }
  throw RenderError(std::string(what) + " failed (VkResult " + std::to_string(result) + ")");
}

VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT, VkDebugUtilsMessageTypeFlagsEXT,
                                          const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  static_cast<VulkanContext*>(user)->record_validation_message(data->pMessage);
  return VK_FALSE;
}

void VulkanContext::record_validation_message(const char* message) {
  ++validation_messages_;
  std::cerr << "hdeform: Vulkan validation: " << message << '\n';
  std::lock_guard lock(messages_mutex_);
  messages_.emplace_back(message);
}

std::vector<std::string> VulkanContext::validation_messages() const {
  std::lock_guard lock(messages_mutex_);
  return messages_;
}

VulkanContext::VulkanContext(const ContextOptions& options) {
  const bool validation = options.validation || environment_flag("HDEFORM_VALIDATION");
  if (validation && !has_layer(kValidationLayer)) {
    throw RenderError("the Vulkan validation layer is not installed (Debian: vulkan-validationlayers)");
  }
  std::vector<const char*> extensions;
  for (const auto& extension : options.instance_extensions) extensions.push_back(extension.c_str());
  if (validation) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  const char* layers[] = {kValidationLayer};

  VkApplicationInfo application{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  application.pApplicationName = "hdeform";
  application.apiVersion = VK_API_VERSION_1_2;
  VkInstanceCreateInfo instance_info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  instance_info.pApplicationInfo = &application;
  instance_info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  instance_info.ppEnabledExtensionNames = extensions.data();
  instance_info.enabledLayerCount = validation ? 1 : 0;
  instance_info.ppEnabledLayerNames = layers;
  VkDebugUtilsMessengerCreateInfoEXT messenger_info{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  messenger_info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messenger_info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messenger_info.pfnUserCallback = on_validation_message;
  messenger_info.pUserData = this;
  if (validation) instance_info.pNext = &messenger_info;  // also covers instance creation itself
  const VkResult created = vkCreateInstance(&instance_info, nullptr, &instance_);
  if (created == VK_ERROR_INCOMPATIBLE_DRIVER) {
    throw RenderError("no Vulkan driver found (install a GPU driver, or mesa-vulkan-drivers for the CPU renderer lavapipe)");
  }
  check(created, "vkCreateInstance");
  try {
    if (validation) {
      auto create_messenger =
          reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
      check(create_messenger(instance_, &messenger_info, nullptr, &messenger_), "vkCreateDebugUtilsMessengerEXT");
    }
    if (options.create_surface) surface_ = options.create_surface(instance_);
    std::string preference = options.device;
    if (preference.empty()) {
      if (const char* from_environment = std::getenv("HDEFORM_VULKAN_DEVICE")) preference = from_environment;
    }
    choose_device(preference, options.announce);

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queue_info{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    queue_info.queueFamilyIndex = queue_family_;
    queue_info.queueCount = 1;
    queue_info.pQueuePriorities = &priority;
    VkPhysicalDeviceVulkan12Features supported12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    VkPhysicalDeviceFeatures2 supported{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    supported.pNext = &supported12;
    vkGetPhysicalDeviceFeatures2(physical_device_, &supported);
    VkPhysicalDeviceVulkan12Features features12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    features12.timelineSemaphore = supported12.timelineSemaphore;  // frame completion times
    timeline_semaphores_ = supported12.timelineSemaphore == VK_TRUE;
    VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    features.pNext = &features12;
    features.features.fillModeNonSolid = supported.features.fillModeNonSolid;  // wireframe overlay
    std::vector<const char*> device_extensions;
    if (surface_ != VK_NULL_HANDLE) device_extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    VkDeviceCreateInfo device_info{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    device_info.pNext = &features;
    device_info.queueCreateInfoCount = 1;
    device_info.pQueueCreateInfos = &queue_info;
    device_info.enabledExtensionCount = static_cast<uint32_t>(device_extensions.size());
    device_info.ppEnabledExtensionNames = device_extensions.data();
    check(vkCreateDevice(physical_device_, &device_info, nullptr, &device_), "vkCreateDevice");
    vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
    VkCommandPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pool_info.queueFamilyIndex = queue_family_;
    check(vkCreateCommandPool(device_, &pool_info, nullptr, &command_pool_), "vkCreateCommandPool");
  } catch (...) {
    release();
    throw;
  }
}

void VulkanContext::choose_device(const std::string& preference, bool announce) {
  uint32_t count = 0;
  vkEnumeratePhysicalDevices(instance_, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(instance_, &count, devices.data());
  if (devices.empty()) {
    throw RenderError("no Vulkan device found (install a GPU driver, or mesa-vulkan-drivers for the CPU renderer lavapipe)");
  }
  struct Candidate {
    VkPhysicalDevice device;
    VkPhysicalDeviceProperties properties;
    uint32_t family;
    std::size_t index;
  };
  std::vector<Candidate> usable;
  std::string seen;
  for (std::size_t index = 0; index < devices.size(); ++index) {
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(devices[index], &properties);
    seen += std::string(seen.empty() ? "" : ", ") + std::to_string(index) + ": " + properties.deviceName + " (" +
            type_name(properties.deviceType) + ")";
    if (properties.apiVersion < VK_API_VERSION_1_2) continue;
    if (surface_ != VK_NULL_HANDLE && !has_device_extension(devices[index], VK_KHR_SWAPCHAIN_EXTENSION_NAME)) continue;
    uint32_t family_count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(devices[index], &family_count, nullptr);
    std::vector<VkQueueFamilyProperties> families(family_count);
    vkGetPhysicalDeviceQueueFamilyProperties(devices[index], &family_count, families.data());
    for (uint32_t family = 0; family < family_count; ++family) {
      if (!(families[family].queueFlags & VK_QUEUE_GRAPHICS_BIT)) continue;
      VkBool32 presents = VK_TRUE;
      if (surface_ != VK_NULL_HANDLE) vkGetPhysicalDeviceSurfaceSupportKHR(devices[index], family, surface_, &presents);
      if (!presents) continue;
      usable.push_back({devices[index], properties, family, index});
      break;
    }
  }
  const std::string wanted = lower(preference);
  auto matches = [&](const Candidate& c) {
    if (wanted.empty()) return true;
    if (wanted == "cpu") return c.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    if (wanted == "gpu") return c.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU ||
                                c.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU;
    if (std::all_of(wanted.begin(), wanted.end(), [](unsigned char ch) { return std::isdigit(ch); })) return std::to_string(c.index) == wanted;
    return lower(c.properties.deviceName).find(wanted) != std::string::npos;
  };
  const Candidate* best = nullptr;
  for (const auto& candidate : usable) {
    if (!matches(candidate)) continue;
    if (best == nullptr || preference_rank(candidate.properties.deviceType) > preference_rank(best->properties.deviceType)) best = &candidate;
  }
  if (best == nullptr) {
    throw RenderError(wanted.empty() ? "no Vulkan 1.2 device can render here (devices: " + seen + ")"
                                     : "no Vulkan device matches '" + preference + "' (devices: " + seen + ")");
  }
  physical_device_ = best->device;
  properties_ = best->properties;
  queue_family_ = best->family;
  vkGetPhysicalDeviceMemoryProperties(physical_device_, &memory_properties_);
  if (announce) {
    std::cerr << "hdeform: Vulkan device " << best->index << ": " << properties_.deviceName << " (" << type_name(properties_.deviceType)
              << ")" << (messenger_ != VK_NULL_HANDLE ? ", validation on" : "") << '\n';
  }
}

VulkanContext::~VulkanContext() { release(); }

void VulkanContext::release() {
  if (device_ != VK_NULL_HANDLE) {
    vkDeviceWaitIdle(device_);
    if (command_pool_ != VK_NULL_HANDLE) vkDestroyCommandPool(device_, command_pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
    device_ = VK_NULL_HANDLE;
  }
  if (instance_ != VK_NULL_HANDLE) {
    if (surface_ != VK_NULL_HANDLE) vkDestroySurfaceKHR(instance_, surface_, nullptr);
    if (messenger_ != VK_NULL_HANDLE) {
      auto destroy_messenger =
          reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
      destroy_messenger(instance_, messenger_, nullptr);
    }
    vkDestroyInstance(instance_, nullptr);
    instance_ = VK_NULL_HANDLE;
  }
}

VkSampleCountFlagBits VulkanContext::supported_samples(int wanted) const {
  const VkSampleCountFlags both =
      properties_.limits.framebufferColorSampleCounts & properties_.limits.framebufferDepthSampleCounts;
  for (int samples = std::min(wanted, 64); samples > 1; samples /= 2) {
    if (both & static_cast<VkSampleCountFlags>(samples)) return static_cast<VkSampleCountFlagBits>(samples);
  }
  return VK_SAMPLE_COUNT_1_BIT;
}

uint32_t VulkanContext::memory_type(uint32_t allowed, VkMemoryPropertyFlags properties) const {
  for (uint32_t i = 0; i < memory_properties_.memoryTypeCount; ++i) {
    if ((allowed & (1u << i)) && (memory_properties_.memoryTypes[i].propertyFlags & properties) == properties) return i;
  }
  throw RenderError("no suitable Vulkan memory type");
}

Buffer VulkanContext::create_buffer(VkDeviceSize size, VkBufferUsageFlags usage) const {
  Buffer buffer;
  buffer.size = std::max<VkDeviceSize>(size, 16);
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = buffer.size;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(device_, &info, nullptr, &buffer.buffer), "vkCreateBuffer");
  VkMemoryRequirements requirements;
  vkGetBufferMemoryRequirements(device_, buffer.buffer, &requirements);
  VkMemoryAllocateInfo allocation{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  allocation.allocationSize = requirements.size;
  allocation.memoryTypeIndex =
      memory_type(requirements.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  const VkResult allocated = vkAllocateMemory(device_, &allocation, nullptr, &buffer.memory);
  if (allocated != VK_SUCCESS) {
    vkDestroyBuffer(device_, buffer.buffer, nullptr);
    check(allocated, "vkAllocateMemory");
  }
  check(vkBindBufferMemory(device_, buffer.buffer, buffer.memory, 0), "vkBindBufferMemory");
  check(vkMapMemory(device_, buffer.memory, 0, VK_WHOLE_SIZE, 0, &buffer.mapped), "vkMapMemory");
  return buffer;
}

void VulkanContext::destroy(Buffer& buffer) const {
  if (buffer.buffer != VK_NULL_HANDLE) vkDestroyBuffer(device_, buffer.buffer, nullptr);
  if (buffer.memory != VK_NULL_HANDLE) vkFreeMemory(device_, buffer.memory, nullptr);
  buffer = Buffer{};
}

Image VulkanContext::create_image(uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage,
                                  VkSampleCountFlagBits samples, VkImageAspectFlags aspect) const {
  Image image;
  VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width, height, 1};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = samples;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  check(vkCreateImage(device_, &info, nullptr, &image.image), "vkCreateImage");
  VkMemoryRequirements requirements;
  vkGetImageMemoryRequirements(device_, image.image, &requirements);
  VkMemoryAllocateInfo allocation{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  allocation.allocationSize = requirements.size;
  allocation.memoryTypeIndex = memory_type(requirements.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  check(vkAllocateMemory(device_, &allocation, nullptr, &image.memory), "vkAllocateMemory");
  check(vkBindImageMemory(device_, image.image, image.memory, 0), "vkBindImageMemory");
  VkImageViewCreateInfo view{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  view.image = image.image;
  view.viewType = VK_IMAGE_VIEW_TYPE_2D;
  view.format = format;
  view.subresourceRange = {aspect, 0, 1, 0, 1};
  check(vkCreateImageView(device_, &view, nullptr, &image.view), "vkCreateImageView");
  return image;
}

void VulkanContext::destroy(Image& image) const {
  if (image.view != VK_NULL_HANDLE) vkDestroyImageView(device_, image.view, nullptr);
  if (image.image != VK_NULL_HANDLE) vkDestroyImage(device_, image.image, nullptr);
  if (image.memory != VK_NULL_HANDLE) vkFreeMemory(device_, image.memory, nullptr);
  image = Image{};
}

void VulkanContext::submit_and_wait(const std::function<void(VkCommandBuffer)>& record) const {
  VkCommandBufferAllocateInfo allocation{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  allocation.commandPool = command_pool_;
  allocation.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  allocation.commandBufferCount = 1;
  VkCommandBuffer commands;
  check(vkAllocateCommandBuffers(device_, &allocation, &commands), "vkAllocateCommandBuffers");
  VkFence fence = VK_NULL_HANDLE;
  try {
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(commands, &begin), "vkBeginCommandBuffer");
    record(commands);
    check(vkEndCommandBuffer(commands), "vkEndCommandBuffer");
    VkFenceCreateInfo fence_info{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    check(vkCreateFence(device_, &fence_info, nullptr, &fence), "vkCreateFence");
    VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &commands;
    {
      std::lock_guard lock(queue_mutex_);
      check(vkQueueSubmit(queue_, 1, &submit, fence), "vkQueueSubmit");
    }
    check(vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  } catch (...) {
    if (fence != VK_NULL_HANDLE) vkDestroyFence(device_, fence, nullptr);
    vkFreeCommandBuffers(device_, command_pool_, 1, &commands);
    throw;
  }
  vkDestroyFence(device_, fence, nullptr);
  vkFreeCommandBuffers(device_, command_pool_, 1, &commands);
}

}  // namespace hdeform::engine

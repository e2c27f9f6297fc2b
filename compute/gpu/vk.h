#pragma once
// One place that includes vulkan.hpp's RAII layer. vk::raii handles are move-only and destroy
// their Vulkan object in the destructor; every call checks its VkResult and throws a
// vk::SystemError whose message names the call (e.g. "vk::Device::createBuffer: ErrorOutOfDeviceMemory").
#include <vulkan/vulkan_raii.hpp>

#include <string>

#include "common/error.h"

namespace cofusion::gpu {

// For the few raw C API calls (e.g. GLFW surface creation): throws cofusion::Error naming `call`.
inline void vk_check(VkResult result, const char* call) {
  if (result != VK_SUCCESS)
    throw Error(std::string(call) + " failed: " + vk::to_string(static_cast<vk::Result>(result)));
}

}  // namespace cofusion::gpu

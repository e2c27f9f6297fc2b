#include "gpu/context.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <thread>

namespace cofusion::gpu {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

std::string device_type_name(vk::PhysicalDeviceType type) {
  switch (type) {
    case vk::PhysicalDeviceType::eDiscreteGpu: return "discrete";
    case vk::PhysicalDeviceType::eIntegratedGpu: return "integrated";
    case vk::PhysicalDeviceType::eVirtualGpu: return "virtual";
    case vk::PhysicalDeviceType::eCpu: return "cpu";
    default: return "other";
  }
}

int device_type_rank(vk::PhysicalDeviceType type) {
  switch (type) {
    case vk::PhysicalDeviceType::eDiscreteGpu: return 4;
    case vk::PhysicalDeviceType::eIntegratedGpu: return 3;
    case vk::PhysicalDeviceType::eVirtualGpu: return 2;
    case vk::PhysicalDeviceType::eCpu: return 1;
    default: return 0;
  }
}

bool has_extension(const std::vector<vk::ExtensionProperties>& list, const char* name) {
  return std::any_of(list.begin(), list.end(),
                     [&](const vk::ExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string version_string(uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
         std::to_string(VK_API_VERSION_PATCH(v));
}

// Family with compute support and the most queues (ties: the first).
std::optional<uint32_t> pick_compute_family(const vk::raii::PhysicalDevice& pd) {
  std::optional<uint32_t> best;
  uint32_t best_count = 0;
  const auto families = pd.getQueueFamilyProperties();
  for (uint32_t i = 0; i < families.size(); ++i) {
    if (!(families[i].queueFlags & vk::QueueFlagBits::eCompute)) continue;
    if (!best || families[i].queueCount > best_count) {
      best = i;
      best_count = families[i].queueCount;
    }
  }
  return best;
}

DeviceInfo describe_device(const vk::raii::PhysicalDevice& pd, uint32_t index) {
  const auto props = pd.getProperties();
  DeviceInfo info;
  info.index = index;
  info.name = props.deviceName.data();
  info.type = device_type_name(props.deviceType);
  info.api_version = props.apiVersion;
  const auto extensions = pd.enumerateDeviceExtensionProperties();
  if (props.apiVersion < VK_API_VERSION_1_3)
    info.why_unusable = "Vulkan " + version_string(props.apiVersion) + " < 1.3";
  else if (!pick_compute_family(pd))
    info.why_unusable = "no compute queue";
  else if (!has_extension(extensions, VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME))
    info.why_unusable = "no VK_KHR_push_descriptor";
  else {
    const auto chain = pd.getFeatures2<vk::PhysicalDeviceFeatures2, vk::PhysicalDeviceVulkan12Features,
                                       vk::PhysicalDeviceVulkan13Features>();
    if (!chain.get<vk::PhysicalDeviceVulkan12Features>().timelineSemaphore)
      info.why_unusable = "no timeline semaphores";
    else if (!chain.get<vk::PhysicalDeviceVulkan13Features>().synchronization2)
      info.why_unusable = "no synchronization2";
  }
  info.usable = info.why_unusable.empty();
  return info;
}

vk::raii::Instance make_instance(const vk::raii::Context& loader, bool validation, bool* debug_utils,
                                 const std::vector<std::string>& extra_extensions = {}) {
  const auto layers = loader.enumerateInstanceLayerProperties();
  const auto extensions = loader.enumerateInstanceExtensionProperties();
  std::vector<const char*> enabled_layers;
  std::vector<const char*> enabled_extensions;
  if (validation) {
    const bool found = std::any_of(layers.begin(), layers.end(), [](const vk::LayerProperties& l) {
      return std::strcmp(l.layerName, kValidationLayer) == 0;
    });
    if (!found)
      throw Error(std::string("validation requested but ") + kValidationLayer +
                  " is not installed (Debian: apt-get install vulkan-validationlayers)");
    enabled_layers.push_back(kValidationLayer);
  }
  *debug_utils = has_extension(extensions, VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  if (*debug_utils) enabled_extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  for (const auto& name : extra_extensions) {
    if (!has_extension(extensions, name.c_str())) throw Error("Vulkan instance extension " + name + " is not available");
    enabled_extensions.push_back(name.c_str());
  }

  vk::ApplicationInfo app{.pApplicationName = "cofusion",
                          .applicationVersion = 1,
                          .pEngineName = "cofusion-vk",
                          .engineVersion = 1,
                          .apiVersion = VK_API_VERSION_1_3};
  vk::InstanceCreateInfo info{.pApplicationInfo = &app,
                              .enabledLayerCount = static_cast<uint32_t>(enabled_layers.size()),
                              .ppEnabledLayerNames = enabled_layers.data(),
                              .enabledExtensionCount = static_cast<uint32_t>(enabled_extensions.size()),
                              .ppEnabledExtensionNames = enabled_extensions.data()};
  return vk::raii::Instance(loader, info);
}

}  // namespace

std::vector<DeviceInfo> Context::list_devices() {
  vk::raii::Context loader;
  bool debug_utils = false;
  vk::raii::Instance instance = make_instance(loader, false, &debug_utils);
  vk::raii::PhysicalDevices devices(instance);
  std::vector<DeviceInfo> out;
  for (uint32_t i = 0; i < devices.size(); ++i) out.push_back(describe_device(devices[i], i));
  return out;
}

namespace {

// The device `--device` names (an index or a name substring), else the best usable one by type
// (a discrete GPU before an integrated one before a CPU implementation).
uint32_t choose_device(const vk::raii::PhysicalDevices& devices, const std::vector<DeviceInfo>& infos,
                       const std::string& sel) {
  if (!sel.empty() && std::all_of(sel.begin(), sel.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    const uint32_t idx = static_cast<uint32_t>(std::stoul(sel));
    if (idx >= infos.size())
      throw Error("--device " + sel + ": only " + std::to_string(infos.size()) + " Vulkan device(s) present");
    return idx;
  }
  if (!sel.empty()) {
    for (const auto& d : infos)
      if (lower(d.name).find(lower(sel)) != std::string::npos) return d.index;
    std::string names;
    for (const auto& d : infos) names += (names.empty() ? "" : ", ") + d.name;
    throw Error("--device '" + sel + "' matches no Vulkan device (present: " + names + ")");
  }
  std::optional<uint32_t> chosen;
  int best_rank = -1;
  for (const auto& d : infos) {
    if (!d.usable) continue;
    const int rank = device_type_rank(devices[d.index].getProperties().deviceType);
    if (rank > best_rank) {
      best_rank = rank;
      chosen = d.index;
    }
  }
  if (!chosen) {
    std::string why;
    for (const auto& d : infos) why += (why.empty() ? "" : "; ") + d.name + ": " + d.why_unusable;
    throw Error("no usable Vulkan device (" + why + ")");
  }
  return *chosen;
}

// Limits, subgroup operations, 64-bit and float atomics and memory heaps of `device`.
DeviceFeatures query_features(const vk::raii::PhysicalDevice& device) {
  DeviceFeatures f;
  const auto props = device.getProperties2<vk::PhysicalDeviceProperties2, vk::PhysicalDeviceSubgroupProperties>();
  const auto& limits = props.get<vk::PhysicalDeviceProperties2>().properties.limits;
  const auto& subgroup = props.get<vk::PhysicalDeviceSubgroupProperties>();
  const auto supported = device.getFeatures2<vk::PhysicalDeviceFeatures2, vk::PhysicalDeviceVulkan12Features>();
  const auto& f10 = supported.get<vk::PhysicalDeviceFeatures2>().features;
  const auto& f12 = supported.get<vk::PhysicalDeviceVulkan12Features>();
  f.buffer_device_address = f12.bufferDeviceAddress;
  f.shader_int64 = f10.shaderInt64;
  f.buffer_int64_atomics = f12.shaderBufferInt64Atomics;
  f.subgroup_size = subgroup.subgroupSize;
  f.subgroup_arithmetic = (subgroup.supportedOperations & vk::SubgroupFeatureFlagBits::eArithmetic) &&
                          (subgroup.supportedStages & vk::ShaderStageFlagBits::eCompute);
  f.max_storage_buffer_range = limits.maxStorageBufferRange;
  f.max_compute_workgroup_invocations = limits.maxComputeWorkGroupInvocations;
  f.timestamp_period_ns = limits.timestampPeriod;
  f.max_texel_buffer_elements = limits.maxTexelBufferElements;
  const auto maint3 = device.getProperties2<vk::PhysicalDeviceProperties2, vk::PhysicalDeviceMaintenance3Properties>();
  f.max_memory_allocation_size = maint3.get<vk::PhysicalDeviceMaintenance3Properties>().maxMemoryAllocationSize;
  const auto memory = device.getMemoryProperties();
  for (uint32_t h = 0; h < memory.memoryHeapCount; ++h)
    if (memory.memoryHeaps[h].flags & vk::MemoryHeapFlagBits::eDeviceLocal)
      f.device_local_heap_bytes = std::max<uint64_t>(f.device_local_heap_bytes, memory.memoryHeaps[h].size);
  for (uint32_t t = 0; t < memory.memoryTypeCount; ++t) {
    const auto flags = memory.memoryTypes[t].propertyFlags;
    using P = vk::MemoryPropertyFlagBits;
    const auto unified = P::eDeviceLocal | P::eHostVisible | P::eHostCoherent | P::eHostCached;
    if ((flags & unified) == unified) f.device_local_memory_is_host_cached = true;
  }
  if (has_extension(device.enumerateDeviceExtensionProperties(), VK_EXT_SHADER_ATOMIC_FLOAT_EXTENSION_NAME)) {
    const auto fa = device.getFeatures2<vk::PhysicalDeviceFeatures2, vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT>();
    f.shader_float_atomic_add = fa.get<vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT>().shaderBufferFloat32AtomicAdd;
  }
  return f;
}

}  // namespace

uint32_t lavapipe_threads(const char* lp_num_threads) {
  if (lp_num_threads && *lp_num_threads) {
    char* end = nullptr;
    const unsigned long n = std::strtoul(lp_num_threads, &end, 10);
    if (end && *end == '\0' && std::isdigit(static_cast<unsigned char>(*lp_num_threads)))
      return static_cast<uint32_t>(std::clamp<unsigned long>(n, 1, 256));
  }
  return std::max(1u, std::thread::hardware_concurrency());
}

Context::Context(const ContextOptions& options) : options_(options) {
  instance_ = make_instance(loader_, options_.validation, &debug_utils_, options_.instance_extensions);
  if (options_.validation && debug_utils_) {
    vk::DebugUtilsMessengerCreateInfoEXT info{
        .messageSeverity = vk::DebugUtilsMessageSeverityFlagBitsEXT::eWarning |
                           vk::DebugUtilsMessageSeverityFlagBitsEXT::eError,
        .messageType = vk::DebugUtilsMessageTypeFlagBitsEXT::eGeneral |
                       vk::DebugUtilsMessageTypeFlagBitsEXT::eValidation |
                       vk::DebugUtilsMessageTypeFlagBitsEXT::ePerformance,
        .pfnUserCallback = &Context::debug_callback,
        .pUserData = this};
    messenger_ = vk::raii::DebugUtilsMessengerEXT(instance_, info);
  }
  vk::raii::PhysicalDevices devices(instance_);
  if (devices.empty()) throw Error("no Vulkan device found (Debian: apt-get install mesa-vulkan-drivers)");
  std::vector<DeviceInfo> infos;
  for (uint32_t i = 0; i < devices.size(); ++i) infos.push_back(describe_device(devices[i], i));
  const uint32_t chosen = choose_device(devices, infos, options_.device);
  info_ = infos[chosen];
  if (!info_.usable) throw Error("Vulkan device '" + info_.name + "' cannot be used: " + info_.why_unusable);
  physical_device_ = std::move(devices[chosen]);
  features_ = query_features(physical_device_);
  software_threads_ = lavapipe_threads(std::getenv("LP_NUM_THREADS"));
  const bool spare_threads = std::thread::hardware_concurrency() >= kMinThreadsToSpin;
  spin_wait_us_ = options_.spin_wait_us >= 0           ? static_cast<uint32_t>(options_.spin_wait_us)
                  : is_software() || !spare_threads ? 0u
                                                    : kDefaultSpinWaitUs;
  create_device();
}

// How many compute queues to use when ContextOptions::max_compute_queues leaves it to the device.
// On NVIDIA one: with 3-6 models this pipeline's many small synchronous submissions (one per ICP
// iteration and model) took 1.6-1.8x longer per frame on 8 queues than on one (H200, driver 580;
// docs/experiments.md). Elsewhere every queue the family offers (up to 8): not measured worse.
namespace {
uint32_t default_compute_queues(const vk::PhysicalDeviceProperties& properties) {
  constexpr uint32_t kNvidiaVendorId = 0x10DE;
  return properties.vendorID == kNvidiaVendorId ? 1u : 8u;
}
}  // namespace

// The logical device with the compute family's queues (at most 8; fewer by max_compute_queues or
// the device's default) and the features used where present.
void Context::create_device() {
  queue_family_ = *pick_compute_family(physical_device_);
  const auto families = physical_device_.getQueueFamilyProperties();
  offered_queue_count_ = families[queue_family_].queueCount;
  const uint32_t limit = options_.max_compute_queues > 0 ? options_.max_compute_queues
                                                         : default_compute_queues(physical_device_.getProperties());
  const uint32_t queue_count = std::min({offered_queue_count_, limit, 8u});
  features_.timestamp_valid_bits = families[queue_family_].timestampValidBits;
  std::vector<float> priorities(queue_count, 1.0f);
  vk::DeviceQueueCreateInfo queue_info{.queueFamilyIndex = queue_family_,
                                       .queueCount = queue_count,
                                       .pQueuePriorities = priorities.data()};

  const auto supported = physical_device_.getFeatures2<vk::PhysicalDeviceFeatures2, vk::PhysicalDeviceVulkan12Features,
                                                       vk::PhysicalDeviceVulkan13Features>();
  const auto& f12 = supported.get<vk::PhysicalDeviceVulkan12Features>();
  vk::PhysicalDeviceFeatures2 enable10{};
  enable10.features.shaderInt64 = features_.shader_int64;
  vk::PhysicalDeviceVulkan11Features enable11{};
  vk::PhysicalDeviceVulkan12Features enable12{};
  enable12.timelineSemaphore = VK_TRUE;
  enable12.bufferDeviceAddress = features_.buffer_device_address;
  enable12.shaderBufferInt64Atomics = features_.buffer_int64_atomics;
  enable12.storageBuffer8BitAccess = f12.storageBuffer8BitAccess;
  enable12.scalarBlockLayout = f12.scalarBlockLayout;
  vk::PhysicalDeviceVulkan13Features enable13{};
  enable13.synchronization2 = VK_TRUE;
  enable13.maintenance4 = supported.get<vk::PhysicalDeviceVulkan13Features>().maintenance4;
  enable10.pNext = &enable11;
  enable11.pNext = &enable12;
  enable12.pNext = &enable13;

  const auto extensions = physical_device_.enumerateDeviceExtensionProperties();
  const bool has_float_atomics = has_extension(extensions, VK_EXT_SHADER_ATOMIC_FLOAT_EXTENSION_NAME);
  vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT float_atomics{};
  float_atomics.shaderBufferFloat32AtomicAdd = features_.shader_float_atomic_add;
  if (has_float_atomics) enable13.pNext = &float_atomics;
  std::vector<const char*> device_extensions{VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME};
  if (has_float_atomics) device_extensions.push_back(VK_EXT_SHADER_ATOMIC_FLOAT_EXTENSION_NAME);
  for (const auto& name : options_.device_extensions) {
    if (!has_extension(extensions, name.c_str()))
      throw Error("Vulkan device extension " + name + " is not supported by " + info_.name);
    device_extensions.push_back(name.c_str());
  }
  vk::DeviceCreateInfo device_info{.pNext = &enable10,
                                   .queueCreateInfoCount = 1,
                                   .pQueueCreateInfos = &queue_info,
                                   .enabledExtensionCount = static_cast<uint32_t>(device_extensions.size()),
                                   .ppEnabledExtensionNames = device_extensions.data()};
  device_ = vk::raii::Device(physical_device_, device_info);
  for (uint32_t i = 0; i < queue_count; ++i) {
    auto q = std::make_unique<Queue>();
    q->handle = *device_.getQueue(queue_family_, i);
    q->family = queue_family_;
    q->index = i;
    set_name_raw(vk::ObjectType::eQueue, reinterpret_cast<uint64_t>(static_cast<VkQueue>(q->handle)),
                 "compute queue " + std::to_string(i));
    queues_.push_back(std::move(q));
  }
}

Context::~Context() {
  if (*device_) device_.waitIdle();
}

std::string Context::description() const {
  return info_.name + " [" + info_.type + ", Vulkan " + version_string(info_.api_version) + "], " +
         std::to_string(queues_.size()) + " of " + std::to_string(offered_queue_count_) + " compute queue" +
         (offered_queue_count_ == 1 ? "" : "s") +
         (spin_wait_us_ > 0 ? ", waits poll up to " + std::to_string(spin_wait_us_) + " us" : "");
}

uint32_t Context::find_memory_type(uint32_t type_bits, vk::MemoryPropertyFlags required,
                                   vk::MemoryPropertyFlags preferred, const std::string& what) const {
  const auto memory = physical_device_.getMemoryProperties();
  std::optional<uint32_t> fallback;
  for (uint32_t t = 0; t < memory.memoryTypeCount; ++t) {
    if (!(type_bits & (1u << t))) continue;
    const auto flags = memory.memoryTypes[t].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return t;
    if (!fallback) fallback = t;
  }
  if (fallback) return *fallback;
  throw Error("no Vulkan memory type with " + vk::to_string(required) + " for " + what);
}

void Context::set_name_raw(vk::ObjectType type, uint64_t handle, const std::string& name) const {
  if (!debug_utils_ || !*device_) return;
  vk::DebugUtilsObjectNameInfoEXT info{.objectType = type, .objectHandle = handle, .pObjectName = name.c_str()};
  device_.setDebugUtilsObjectNameEXT(info);
}

VKAPI_ATTR VkBool32 VKAPI_CALL Context::debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                       VkDebugUtilsMessageTypeFlagsEXT,
                                                       const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* self = static_cast<Context*>(user);
  const std::string message = data && data->pMessage ? data->pMessage : "(no message)";
  if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    self->validation_errors_++;
    std::fprintf(stderr, "[vulkan validation error] %s\n", message.c_str());
    if (self->options_.on_validation_error) self->options_.on_validation_error(message);
  } else if (self->options_.print_validation_warnings) {
    std::fprintf(stderr, "[vulkan validation warning] %s\n", message.c_str());
  }
  return VK_FALSE;
}

void Context::set_kernel_profile(std::shared_ptr<KernelProfile> profile) {
  if (profile && (features_.timestamp_valid_bits == 0 || features_.timestamp_period_ns <= 0.0f))
    throw Error("kernel profile: the compute queues of '" + info_.name + "' cannot write timestamps");
  kernel_profile_ = std::move(profile);
}

}  // namespace cofusion::gpu

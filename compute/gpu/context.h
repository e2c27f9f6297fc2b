#pragma once
// The Vulkan instance, the chosen physical device, the logical device and its compute queues.
//
// Device choice: a real GPU is preferred (discrete > integrated > virtual > CPU such as Mesa
// lavapipe); ContextOptions::device picks one by index or by a case-insensitive name substring.
// Queues: every queue of the compute-capable family with the most queues is created. Workers ask
// for queue_for_worker(i): with several queues each worker gets its own, with one (lavapipe)
// they share it; submission to a shared queue is serialised by the queue's mutex.
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <type_traits>
#include <vector>

#include "gpu/kernel_profile.h"
#include "gpu/vk.h"

namespace cofusion::gpu {

struct ContextOptions {
  // Enable VK_LAYER_KHRONOS_validation and a messenger. Always on in tests.
  bool validation = false;
  // "" = best device; a number = index in the enumeration order (see list_devices());
  // anything else = first device whose name contains it (case-insensitive).
  std::string device;
  // Never map device buffers, even on unified memory, so every upload/download takes the staging
  // path that discrete GPUs need. For tests of that path on lavapipe.
  bool force_staging = false;
  // At most this many compute queues (0: the device's default: one on NVIDIA, where several ran
  // slower, else every queue of the family, up to 8). With 1, per-model work shares one queue.
  uint32_t max_compute_queues = 0;
  // How long a wait for the GPU first polls the timeline on the host before it sleeps in the
  // driver, in microseconds. Negative: by device - kDefaultSpinWaitUs on a GPU, where a sleeping
  // wait wakes up to 0.1 ms after the GPU finishes and a frame has dozens of short round trips;
  // 0 where the device is the CPU itself, whose cores a polling host would take, or where the host
  // has fewer than kMinThreadsToSpin hardware threads (the polling thread would take one from the
  // CPU jobs that run beside the GPU's work).
  int spin_wait_us = -1;
  // Called for every validation message of error severity (after it is counted and printed).
  // Tests turn it into a test failure.
  std::function<void(const std::string& message)> on_validation_error;
  // Print validation warnings too (errors are always printed).
  bool print_validation_warnings = true;
  // Extra extensions, for presentation (the viewer window): instance extensions such as those
  // glfwGetRequiredInstanceExtensions names, device extensions such as VK_KHR_swapchain. A missing
  // one is an error naming it.
  std::vector<std::string> instance_extensions;
  std::vector<std::string> device_extensions;
};

struct DeviceInfo {
  uint32_t index = 0;
  std::string name;
  std::string type;  // "discrete", "integrated", "virtual", "cpu", "other"
  uint32_t api_version = 0;
  bool usable = false;        // meets our requirements (Vulkan 1.3, compute, push descriptors)
  std::string why_unusable;   // when !usable
};

struct DeviceFeatures {
  bool buffer_device_address = false;
  bool shader_int64 = false;
  bool buffer_int64_atomics = false;
  bool shader_float_atomic_add = false;
  uint32_t subgroup_size = 1;
  bool subgroup_arithmetic = false;
  uint64_t max_storage_buffer_range = 0;
  uint64_t max_memory_allocation_size = 0;
  uint64_t device_local_heap_bytes = 0;
  // A device-local memory type that is also host-visible, coherent and cached: unified memory
  // (lavapipe, integrated GPUs), where the host reads mapped device buffers at memory speed.
  // Discrete GPUs with resizable BAR offer device-local host-visible memory too, but uncached:
  // host reads from it are orders of magnitude slower, so there buffers use staging instead.
  bool device_local_memory_is_host_cached = false;
  uint32_t max_compute_workgroup_invocations = 0;
  float timestamp_period_ns = 0;
  uint32_t timestamp_valid_bits = 0;  // of the compute queue family; 0: no timestamps
  uint64_t max_texel_buffer_elements = 0;
};

// Device memory held by live gpu::Buffers (the VkDeviceMemory of each; the only device memory
// the project allocates). Shared by the Context and its buffers. Thread-safe.
struct DeviceMemoryCounter {
  std::atomic<uint64_t> bytes{0};
  std::atomic<uint64_t> allocations{0};
};

// One device queue. Submissions from several threads to the same queue are serialised by `mutex`.
struct Queue {
  vk::Queue handle;
  uint32_t family = 0;
  uint32_t index = 0;
  std::mutex mutex;
};

// How many threads lavapipe (Mesa's llvmpipe) gives a dispatch: one per online CPU of the host,
// or the value of LP_NUM_THREADS (`lp_num_threads`, null when unset) where that is a number
// (0, lavapipe's "in the calling thread", counts as 1).
uint32_t lavapipe_threads(const char* lp_num_threads);

class Context {
 public:
  explicit Context(const ContextOptions& options = {});
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  // Every physical device the loader reports, with why a device cannot be used.
  static std::vector<DeviceInfo> list_devices();

  const vk::raii::Instance& instance() const { return instance_; }
  const vk::raii::Device& device() const { return device_; }
  const vk::raii::PhysicalDevice& physical_device() const { return physical_device_; }
  const DeviceInfo& info() const { return info_; }
  const DeviceFeatures& features() const { return features_; }
  const ContextOptions& options() const { return options_; }
  // e.g. "llvmpipe (LLVM 15.0.6, 256 bits) [cpu, Vulkan 1.3.230], 1 of 1 compute queue"
  std::string description() const;
  bool is_software() const { return info_.type == "cpu"; }
  // Threads a CPU device runs one dispatch's workgroups on (lavapipe_threads with this process's
  // LP_NUM_THREADS). Meaningless for a GPU.
  uint32_t software_threads() const { return software_threads_; }
  // ContextOptions::spin_wait_us resolved for this device.
  uint32_t spin_wait_us() const { return spin_wait_us_; }
  static constexpr uint32_t kDefaultSpinWaitUs = 2000;
  static constexpr unsigned kMinThreadsToSpin = 4;

  uint32_t compute_queue_count() const { return static_cast<uint32_t>(queues_.size()); }
  uint32_t compute_queue_family() const { return queue_family_; }
  // One queue per concurrent worker where there are several; the shared one where there is one.
  Queue& queue_for_worker(uint32_t worker) { return *queues_[worker % queues_.size()]; }

  // Memory type for the requested properties, or throws naming `what`.
  uint32_t find_memory_type(uint32_t type_bits, vk::MemoryPropertyFlags required,
                            vk::MemoryPropertyFlags preferred, const std::string& what) const;

  // Debug name shown by validation messages and tools (no-op without VK_EXT_debug_utils).
  template <typename RaiiHandle>
  void set_name(const RaiiHandle& handle, const std::string& name) const {
    const auto h = *handle;  // the vk:: (non-owning) handle
    using Handle = std::remove_const_t<decltype(h)>;
    set_name_raw(Handle::objectType, reinterpret_cast<uint64_t>(static_cast<typename Handle::CType>(h)), name);
  }
  void set_name_raw(vk::ObjectType type, uint64_t handle, const std::string& name) const;

  // Per-kernel GPU timing (see kernel_profile.h): streams record timestamps around every
  // dispatch while a profile is attached; nullptr detaches. Throws where the compute queues
  // cannot write timestamps. Attach before recording work; lists begun earlier are not timed.
  void set_kernel_profile(std::shared_ptr<KernelProfile> profile);
  KernelProfile* kernel_profile() const { return kernel_profile_.get(); }

  // Bytes of device memory (and number of allocations) that the project's buffers hold now.
  uint64_t allocated_device_bytes() const { return memory_->bytes.load(); }
  uint64_t live_device_allocations() const { return memory_->allocations.load(); }
  const std::shared_ptr<DeviceMemoryCounter>& memory_counter() const { return memory_; }

  // Number of validation messages of error severity seen so far.
  size_t validation_error_count() const { return validation_errors_.load(); }

 private:
  void create_device();
  static VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                       VkDebugUtilsMessageTypeFlagsEXT types,
                                                       const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                       void* user);

  ContextOptions options_;
  vk::raii::Context loader_;
  vk::raii::Instance instance_{nullptr};
  vk::raii::DebugUtilsMessengerEXT messenger_{nullptr};
  vk::raii::PhysicalDevice physical_device_{nullptr};
  vk::raii::Device device_{nullptr};
  DeviceInfo info_;
  uint32_t software_threads_ = 1;
  uint32_t spin_wait_us_ = 0;
  DeviceFeatures features_;
  bool debug_utils_ = false;
  uint32_t queue_family_ = 0;
  std::vector<std::unique_ptr<Queue>> queues_;
  uint32_t offered_queue_count_ = 0;  // queues of the chosen family
  std::atomic<size_t> validation_errors_{0};
  std::shared_ptr<KernelProfile> kernel_profile_;
  std::shared_ptr<DeviceMemoryCounter> memory_ = std::make_shared<DeviceMemoryCounter>();
};

}  // namespace cofusion::gpu

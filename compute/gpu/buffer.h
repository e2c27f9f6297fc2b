#pragma once
// A storage buffer and its memory. Device buffers are host-mapped where device-local memory is
// also host-cached (unified memory: lavapipe, integrated GPUs); otherwise (discrete GPUs, with or
// without resizable BAR) uploads and downloads go through a staging buffer. Buffers are
// shared_ptr-owned so a command list can keep the ones it uses alive until its submission has
// finished on the GPU.
#include <cstddef>
#include <memory>
#include <span>
#include <string>

#include "gpu/context.h"

namespace cofusion::gpu {

enum class BufferUsage {
  Device,    // working storage of kernels (device-local; mapped only on unified memory)
  Indirect,  // the same, also read by the GPU as indirect dispatch arguments (CommandList::dispatch_indirect)
  Staging,   // host-visible, host-coherent transfer source/destination
};

// Thrown when the device has no memory left for a buffer (allocation failed, or larger than its
// memory heap): callers that can do with less (a surfel model that would grow) catch this one.
class DeviceMemoryError : public Error {
 public:
  using Error::Error;
};

class Buffer;
using BufferPtr = std::shared_ptr<Buffer>;

class Buffer {
 public:
  // `size_bytes` is rounded up to a multiple of 4 (and at least 4: Vulkan has no empty buffers).
  // Throws DeviceMemoryError naming the buffer when the device has no memory for it, and
  // cofusion::Error when it can never hold it (larger than its largest allocation).
  static BufferPtr create(Context& ctx, size_t size_bytes, const std::string& name,
                          BufferUsage usage = BufferUsage::Device);
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  ~Buffer();

  size_t size() const { return size_; }
  const std::string& name() const { return name_; }
  BufferUsage usage() const { return usage_; }
  vk::Buffer handle() const { return *buffer_; }
  // Host pointer when mapped, nullptr otherwise.
  void* mapped() const { return mapped_; }
  // GPU virtual address when the device supports buffer device addresses, 0 otherwise.
  uint64_t device_address() const { return address_; }
  // The buffer as a uniform texel buffer of RGBA32UI texels (16 bytes each), for kernels that
  // gather from it (ComputePipeline's texel bindings): lavapipe fetches texels with vector
  // gathers, but loads storage buffers at scattered offsets lane by lane. Throws naming the
  // buffer where it has none (staging buffers, less than 16 bytes, beyond the device's limit).
  vk::BufferView texel_view() const;

 private:
  Buffer(Context& ctx, size_t size_bytes, const std::string& name, BufferUsage usage);
  std::string name_;
  size_t size_ = 0;
  BufferUsage usage_ = BufferUsage::Device;
  vk::raii::Buffer buffer_{nullptr};
  vk::raii::DeviceMemory memory_{nullptr};
  vk::raii::BufferView texel_view_{nullptr};
  void* mapped_ = nullptr;
  uint64_t address_ = 0;
  // Counted in the context's DeviceMemoryCounter while this buffer lives.
  std::shared_ptr<DeviceMemoryCounter> memory_counter_;
  uint64_t memory_bytes_ = 0;
};

}  // namespace cofusion::gpu

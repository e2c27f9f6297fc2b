#include "gpu/buffer.h"

namespace cofusion::gpu {

BufferPtr Buffer::create(Context& ctx, size_t size_bytes, const std::string& name, BufferUsage usage) {
  return BufferPtr(new Buffer(ctx, size_bytes, name, usage));
}

Buffer::Buffer(Context& ctx, size_t size_bytes, const std::string& name, BufferUsage usage) : name_(name) {
  size_ = std::max<size_t>(4, (size_bytes + 3) / 4 * 4);
  const auto& features = ctx.features();
  if (features.max_memory_allocation_size && size_ > features.max_memory_allocation_size)
    throw Error("buffer '" + name + "' of " + std::to_string(size_) + " bytes exceeds the device's largest allocation (" +
                std::to_string(features.max_memory_allocation_size) + " bytes)");
  if (features.device_local_heap_bytes && size_ > features.device_local_heap_bytes)
    throw Error("buffer '" + name + "' of " + std::to_string(size_) + " bytes exceeds device memory (" +
                std::to_string(features.device_local_heap_bytes) + " bytes)");

  const bool bda = features.buffer_device_address && usage == BufferUsage::Device;
  vk::BufferUsageFlags flags = vk::BufferUsageFlagBits::eTransferSrc | vk::BufferUsageFlagBits::eTransferDst;
  if (usage == BufferUsage::Device) flags |= vk::BufferUsageFlagBits::eStorageBuffer;
  if (bda) flags |= vk::BufferUsageFlagBits::eShaderDeviceAddress;
  buffer_ = vk::raii::Buffer(ctx.device(), vk::BufferCreateInfo{.size = size_, .usage = flags,
                                                                .sharingMode = vk::SharingMode::eExclusive});
  ctx.set_name(buffer_, name);

  const auto requirements = buffer_.getMemoryRequirements();
  using P = vk::MemoryPropertyFlagBits;
  uint32_t type = 0;
  bool map = false;
  if (usage == BufferUsage::Staging) {
    type = ctx.find_memory_type(requirements.memoryTypeBits, P::eHostVisible | P::eHostCoherent, P::eHostCached, name);
    map = true;
  } else if (!ctx.options().force_staging && features.device_local_memory_is_host_visible) {
    type = ctx.find_memory_type(requirements.memoryTypeBits, P::eDeviceLocal | P::eHostVisible | P::eHostCoherent, {},
                                name);
    map = true;
  } else {
    type = ctx.find_memory_type(requirements.memoryTypeBits, P::eDeviceLocal, {}, name);
  }
  vk::MemoryAllocateFlagsInfo allocate_flags{.flags = vk::MemoryAllocateFlagBits::eDeviceAddress};
  vk::MemoryAllocateInfo allocate{.pNext = bda ? &allocate_flags : nullptr,
                                  .allocationSize = requirements.size,
                                  .memoryTypeIndex = type};
  try {
    memory_ = vk::raii::DeviceMemory(ctx.device(), allocate);
  } catch (const vk::SystemError& e) {
    throw Error("cannot allocate " + std::to_string(requirements.size) + " bytes for buffer '" + name + "': " + e.what());
  }
  ctx.set_name(memory_, name + " memory");
  buffer_.bindMemory(*memory_, 0);
  if (map) mapped_ = memory_.mapMemory(0, VK_WHOLE_SIZE);
  if (bda) address_ = ctx.device().getBufferAddress(vk::BufferDeviceAddressInfo{.buffer = *buffer_});
}

}  // namespace cofusion::gpu

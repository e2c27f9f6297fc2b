#include "gpu/buffer.h"

namespace cofusion::gpu {

BufferPtr Buffer::create(Context& ctx, size_t size_bytes, const std::string& name, BufferUsage usage) {
  return BufferPtr(new Buffer(ctx, size_bytes, name, usage));
}

Buffer::Buffer(Context& ctx, size_t size_bytes, const std::string& name, BufferUsage usage)
    : name_(name), usage_(usage) {
  size_ = std::max<size_t>(4, (size_bytes + 3) / 4 * 4);
  const auto& features = ctx.features();
  if (features.max_memory_allocation_size && size_ > features.max_memory_allocation_size)
    throw Error("buffer '" + name + "' of " + std::to_string(size_) + " bytes exceeds the device's largest allocation (" +
                std::to_string(features.max_memory_allocation_size) + " bytes)");
  if (features.device_local_heap_bytes && size_ > features.device_local_heap_bytes)
    throw DeviceMemoryError("buffer '" + name + "' of " + std::to_string(size_) + " bytes exceeds device memory (" +
                std::to_string(features.device_local_heap_bytes) + " bytes)");

  const bool device = usage != BufferUsage::Staging;
  const bool bda = features.buffer_device_address && device;
  vk::BufferUsageFlags flags = vk::BufferUsageFlagBits::eTransferSrc | vk::BufferUsageFlagBits::eTransferDst;
  // The Vulkan buffer is a whole number of 16-byte texels, so that the texel view reaches every
  // byte of size_.
  const size_t vk_size = (size_ + 15) / 16 * 16;
  const uint64_t texels = vk_size / 16;
  const bool texel_view = device && texels > 0 && texels <= features.max_texel_buffer_elements;
  if (device) flags |= vk::BufferUsageFlagBits::eStorageBuffer;
  if (usage == BufferUsage::Indirect) flags |= vk::BufferUsageFlagBits::eIndirectBuffer;
  if (texel_view) flags |= vk::BufferUsageFlagBits::eUniformTexelBuffer;
  if (bda) flags |= vk::BufferUsageFlagBits::eShaderDeviceAddress;
  buffer_ = vk::raii::Buffer(ctx.device(), vk::BufferCreateInfo{.size = vk_size, .usage = flags,
                                                                .sharingMode = vk::SharingMode::eExclusive});
  ctx.set_name(buffer_, name);

  const auto requirements = buffer_.getMemoryRequirements();
  using P = vk::MemoryPropertyFlagBits;
  uint32_t type = 0;
  bool map = false;
  if (usage == BufferUsage::Staging) {
    type = ctx.find_memory_type(requirements.memoryTypeBits, P::eHostVisible | P::eHostCoherent, P::eHostCached, name);
    map = true;
  } else if (!ctx.options().force_staging && features.device_local_memory_is_host_cached) {
    type = ctx.find_memory_type(requirements.memoryTypeBits,
                                P::eDeviceLocal | P::eHostVisible | P::eHostCoherent | P::eHostCached, {}, name);
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
  } catch (const vk::OutOfDeviceMemoryError& e) {
    throw DeviceMemoryError("cannot allocate " + std::to_string(requirements.size) + " bytes for buffer '" + name +
                            "': " + e.what());
  } catch (const vk::OutOfHostMemoryError& e) {
    throw DeviceMemoryError("cannot allocate " + std::to_string(requirements.size) + " bytes for buffer '" + name +
                            "': " + e.what());
  } catch (const vk::SystemError& e) {
    throw Error("cannot allocate " + std::to_string(requirements.size) + " bytes for buffer '" + name + "': " + e.what());
  }
  memory_counter_ = ctx.memory_counter();
  memory_bytes_ = requirements.size;
  memory_counter_->bytes += memory_bytes_;
  ++memory_counter_->allocations;
  ctx.set_name(memory_, name + " memory");
  buffer_.bindMemory(*memory_, 0);
  if (map) mapped_ = memory_.mapMemory(0, VK_WHOLE_SIZE);
  if (bda) address_ = ctx.device().getBufferAddress(vk::BufferDeviceAddressInfo{.buffer = *buffer_});
  if (texel_view) {
    texel_view_ = vk::raii::BufferView(ctx.device(), vk::BufferViewCreateInfo{.buffer = *buffer_,
                                                                              .format = vk::Format::eR32G32B32A32Uint,
                                                                              .offset = 0,
                                                                              .range = vk_size});
    ctx.set_name(texel_view_, name + " texels");
  }
}

Buffer::~Buffer() {
  if (!memory_counter_) return;
  memory_counter_->bytes -= memory_bytes_;
  --memory_counter_->allocations;
}

vk::BufferView Buffer::texel_view() const {
  if (!*texel_view_)
    throw Error("buffer '" + name_ + "' (" + std::to_string(size_) + " bytes) cannot be read as a texel buffer");
  return *texel_view_;
}

}  // namespace cofusion::gpu

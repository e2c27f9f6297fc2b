#include "gpu/stream.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <limits>

namespace cofusion::gpu {

void CommandList::dispatch(const ComputePipeline& pipeline, std::initializer_list<BufferPtr> buffers, const void* push,
                           uint32_t push_bytes, uint32_t groups_x, uint32_t groups_y, uint32_t groups_z) {
  check(pipeline, buffers.size(), push_bytes);
  if (groups_x == 0 || groups_y == 0 || groups_z == 0) return;
  bind(pipeline, buffers, push, push_bytes);
  record_timed(pipeline, [&] { cmd_.dispatch(groups_x, groups_y, groups_z); });
}

void CommandList::dispatch_indirect(const ComputePipeline& pipeline, std::initializer_list<BufferPtr> buffers,
                                    const void* push, uint32_t push_bytes, const BufferPtr& args, size_t offset) {
  if (!args) throw Error("indirect dispatch of '" + pipeline.name() + "': null arguments buffer");
  if (args->usage() != BufferUsage::Indirect)
    throw Error("indirect dispatch of '" + pipeline.name() + "': arguments buffer '" + args->name() +
                "' was not created with BufferUsage::Indirect");
  if (offset % 4 != 0 || offset + sizeof(VkDispatchIndirectCommand) > args->size())
    throw Error("indirect dispatch of '" + pipeline.name() + "': arguments at byte " + std::to_string(offset) +
                " are unaligned or outside '" + args->name() + "'");
  check(pipeline, buffers.size(), push_bytes);
  bind(pipeline, buffers, push, push_bytes);
  held_.push_back(args);
  record_timed(pipeline, [&] { cmd_.dispatchIndirect(args->handle(), offset); });
}

void CommandList::check(const ComputePipeline& pipeline, size_t buffer_count, uint32_t push_bytes) {
  if (buffer_count != pipeline.binding_count())
    throw Error("dispatch of '" + pipeline.name() + "': " + std::to_string(buffer_count) + " buffers for " +
                std::to_string(pipeline.binding_count()) + " bindings");
  if (push_bytes != pipeline.push_constant_bytes())
    throw Error("dispatch of '" + pipeline.name() + "': " + std::to_string(push_bytes) + " bytes of parameters, expected " +
                std::to_string(pipeline.push_constant_bytes()));
}

void CommandList::bind(const ComputePipeline& pipeline, std::initializer_list<BufferPtr> buffers, const void* push,
                       uint32_t push_bytes) {
  std::vector<vk::DescriptorBufferInfo> infos;
  std::vector<vk::BufferView> views;
  infos.reserve(buffers.size());
  views.reserve(buffers.size());
  for (const auto& b : buffers) {
    if (!b) throw Error("dispatch of '" + pipeline.name() + "': null buffer");
    infos.push_back({.buffer = b->handle(), .offset = 0, .range = VK_WHOLE_SIZE});
    views.push_back(pipeline.is_texel_binding(uint32_t(views.size())) ? b->texel_view() : vk::BufferView{});
    held_.push_back(b);
  }
  std::vector<vk::WriteDescriptorSet> writes;
  for (uint32_t i = 0; i < infos.size(); ++i) {
    if (pipeline.is_texel_binding(i))
      writes.push_back({.dstBinding = i,
                        .descriptorCount = 1,
                        .descriptorType = vk::DescriptorType::eUniformTexelBuffer,
                        .pTexelBufferView = &views[i]});
    else
      writes.push_back({.dstBinding = i,
                        .descriptorCount = 1,
                        .descriptorType = vk::DescriptorType::eStorageBuffer,
                        .pBufferInfo = &infos[i]});
  }
  cmd_.bindPipeline(vk::PipelineBindPoint::eCompute, pipeline.handle());
  cmd_.pushDescriptorSetKHR(vk::PipelineBindPoint::eCompute, pipeline.layout(), 0, writes);
  if (push_bytes)
    cmd_.getDispatcher()->vkCmdPushConstants(*cmd_, pipeline.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes, push);
}

template <typename Dispatch>
void CommandList::record_timed(const ComputePipeline& pipeline, Dispatch&& dispatch) {
  if (!timing_) {
    dispatch();
    return;
  }
  const uint32_t query = 2 * static_cast<uint32_t>(timing_->names.size()) % Timing::kQueriesPerPool;
  if (query == 0) {
    timing_->pools.emplace_back(timing_->ctx->device(),
                                vk::QueryPoolCreateInfo{.queryType = vk::QueryType::eTimestamp,
                                                        .queryCount = Timing::kQueriesPerPool});
    cmd_.resetQueryPool(*timing_->pools.back(), 0, Timing::kQueriesPerPool);
  }
  // Both stamps after all earlier commands: the interval is this dispatch (and any work still
  // overlapping it), not the wait for earlier work to start.
  const vk::QueryPool pool = *timing_->pools.back();
  cmd_.writeTimestamp2(vk::PipelineStageFlagBits2::eAllCommands, pool, query);
  dispatch();
  cmd_.writeTimestamp2(vk::PipelineStageFlagBits2::eAllCommands, pool, query + 1);
  timing_->names.push_back(timing_->label.empty() ? pipeline.name() : pipeline.name() + " " + timing_->label);
  timing_->groups.push_back(timing_->group);
}

void CommandList::set_profile_label(const std::string& label) {
  if (timing_) timing_->label = label;
}

void CommandList::set_profile_group(const std::string& group) {
  if (timing_) timing_->group = group;
}

void CommandList::barrier() {
  using S = vk::PipelineStageFlagBits2;
  using A = vk::AccessFlagBits2;
  vk::MemoryBarrier2 b{.srcStageMask = S::eComputeShader | S::eTransfer,
                       .srcAccessMask = A::eShaderStorageWrite | A::eTransferWrite,
                       .dstStageMask = S::eComputeShader | S::eTransfer,
                       .dstAccessMask = A::eShaderStorageRead | A::eShaderStorageWrite | A::eTransferRead |
                                        A::eTransferWrite};
  cmd_.pipelineBarrier2(vk::DependencyInfo{.memoryBarrierCount = 1, .pMemoryBarriers = &b});
}

void CommandList::indirect_barrier() {
  using S = vk::PipelineStageFlagBits2;
  using A = vk::AccessFlagBits2;
  vk::MemoryBarrier2 b{.srcStageMask = S::eComputeShader | S::eTransfer,
                       .srcAccessMask = A::eShaderStorageWrite | A::eTransferWrite,
                       .dstStageMask = S::eComputeShader | S::eTransfer | S::eDrawIndirect,
                       .dstAccessMask = A::eShaderStorageRead | A::eShaderStorageWrite | A::eTransferRead |
                                        A::eTransferWrite | A::eIndirectCommandRead};
  cmd_.pipelineBarrier2(vk::DependencyInfo{.memoryBarrierCount = 1, .pMemoryBarriers = &b});
}

void CommandList::copy(const BufferPtr& src, const BufferPtr& dst, size_t bytes, size_t src_offset, size_t dst_offset) {
  if (bytes == 0) return;
  if (src_offset + bytes > src->size() || dst_offset + bytes > dst->size())
    throw Error("copy of " + std::to_string(bytes) + " bytes from '" + src->name() + "' to '" + dst->name() +
                "' is out of range");
  cmd_.copyBuffer(src->handle(), dst->handle(), vk::BufferCopy{.srcOffset = src_offset, .dstOffset = dst_offset, .size = bytes});
  held_.push_back(src);
  held_.push_back(dst);
}

void CommandList::fill(const BufferPtr& dst, uint32_t value) {
  cmd_.fillBuffer(dst->handle(), 0, VK_WHOLE_SIZE, value);
  held_.push_back(dst);
}

void CommandList::fill(const BufferPtr& dst, uint32_t value, size_t offset, size_t bytes) {
  if (offset % 4 != 0 || bytes % 4 != 0 || offset + bytes > dst->size())
    throw Error("fill of '" + dst->name() + "': " + std::to_string(bytes) + " bytes at " + std::to_string(offset) +
                " is unaligned or outside its " + std::to_string(dst->size()) + " bytes");
  if (bytes == 0) return;
  cmd_.fillBuffer(dst->handle(), offset, bytes, value);
  held_.push_back(dst);
}

Stream::Stream(Context& ctx, uint32_t worker, const std::string& name)
    : ctx_(ctx), queue_(ctx.queue_for_worker(worker)), name_(name), profile_group_(name) {
  pool_ = vk::raii::CommandPool(ctx.device(), vk::CommandPoolCreateInfo{
                                                  .flags = vk::CommandPoolCreateFlagBits::eResetCommandBuffer,
                                                  .queueFamilyIndex = queue_.family});
  ctx.set_name(pool_, name + " command pool");
  vk::SemaphoreTypeCreateInfo type{.semaphoreType = vk::SemaphoreType::eTimeline, .initialValue = 0};
  timeline_ = vk::raii::Semaphore(ctx.device(), vk::SemaphoreCreateInfo{.pNext = &type});
  ctx.set_name(timeline_, name + " timeline");
}

Stream::~Stream() {
  try {
    wait_idle();
  } catch (...) {
    // Destructors must not throw; the device is being torn down anyway.
  }
}

CommandList Stream::begin() {
  collect_finished();
  vk::raii::CommandBuffer cmd{nullptr};
  if (!recycled_.empty()) {
    cmd = std::move(recycled_.back());
    recycled_.pop_back();
    cmd.reset();
  } else {
    vk::raii::CommandBuffers allocated(ctx_.device(), vk::CommandBufferAllocateInfo{.commandPool = *pool_,
                                                                                     .level = vk::CommandBufferLevel::ePrimary,
                                                                                     .commandBufferCount = 1});
    cmd = std::move(allocated[0]);
    ctx_.set_name(cmd, name_ + " commands");
  }
  cmd.begin(vk::CommandBufferBeginInfo{.flags = vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
  std::unique_ptr<CommandList::Timing> timing;
  if (ctx_.kernel_profile()) {
    timing = std::make_unique<CommandList::Timing>();
    timing->ctx = &ctx_;
  }
  return CommandList(std::move(cmd), std::move(timing));
}

TimelinePoint Stream::submit(CommandList&& list, std::span<const TimelinePoint> waits) {
  // Device writes become visible to host reads of mapped memory once the timeline value is seen.
  using S = vk::PipelineStageFlagBits2;
  using A = vk::AccessFlagBits2;
  vk::MemoryBarrier2 to_host{.srcStageMask = S::eComputeShader | S::eTransfer,
                             .srcAccessMask = A::eShaderStorageWrite | A::eTransferWrite,
                             .dstStageMask = S::eHost,
                             .dstAccessMask = A::eHostRead};
  list.cmd_.pipelineBarrier2(vk::DependencyInfo{.memoryBarrierCount = 1, .pMemoryBarriers = &to_host});
  list.cmd_.end();
  const uint64_t value = next_value_ + 1;
  std::vector<vk::SemaphoreSubmitInfo> wait_infos;
  const auto add_wait = [&](const TimelinePoint& w) {
    wait_infos.push_back({.semaphore = w.semaphore, .value = w.value, .stageMask = vk::PipelineStageFlagBits2::eAllCommands});
  };
  for (const auto& w : waits) add_wait(w);
  for (const auto& w : next_waits_) add_wait(w);
  next_waits_.clear();
  vk::SemaphoreSubmitInfo signal{.semaphore = *timeline_, .value = value, .stageMask = vk::PipelineStageFlagBits2::eAllCommands};
  vk::CommandBufferSubmitInfo cmd_info{.commandBuffer = *list.cmd_};
  vk::SubmitInfo2 submit{.waitSemaphoreInfoCount = static_cast<uint32_t>(wait_infos.size()),
                         .pWaitSemaphoreInfos = wait_infos.data(),
                         .commandBufferInfoCount = 1,
                         .pCommandBufferInfos = &cmd_info,
                         .signalSemaphoreInfoCount = 1,
                         .pSignalSemaphoreInfos = &signal};
  {
    std::lock_guard lock(queue_.mutex);
    queue_.handle.submit2(submit);
  }
  next_value_ = value;
  in_flight_.push_back({value, std::move(list.cmd_), std::move(list.held_), std::move(list.timing_)});
  return {*timeline_, value};
}

uint64_t Stream::completed_value() const { return timeline_.getCounterValue(); }

void Stream::wait(const TimelinePoint& point) {
  if (poll_until_reached(point)) {
    collect_finished();
    return;
  }
  vk::SemaphoreWaitInfo info{.semaphoreCount = 1, .pSemaphores = &point.semaphore, .pValues = &point.value};
  const vk::Result r = ctx_.device().waitSemaphores(info, std::numeric_limits<uint64_t>::max());
  if (r != vk::Result::eSuccess) throw Error("waiting for stream '" + name_ + "' failed: " + vk::to_string(r));
  collect_finished();
}

bool Stream::poll_until_reached(const TimelinePoint& point) const {
  const uint32_t spin_us = ctx_.spin_wait_us();
  if (spin_us == 0) return false;
  const auto& device = ctx_.device();
  const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(spin_us);
  do {
    uint64_t value = 0;
    const vk::Result r = static_cast<vk::Result>(
        device.getDispatcher()->vkGetSemaphoreCounterValue(*device, point.semaphore, &value));
    if (r != vk::Result::eSuccess) return false;  // the blocking wait reports the error
    if (value >= point.value) return true;
  } while (std::chrono::steady_clock::now() < until);
  return false;
}

void Stream::wait_idle() {
  if (next_value_ > 0) wait({*timeline_, next_value_});
}

void Stream::collect_finished() {
  const uint64_t done = completed_value();
  while (!in_flight_.empty() && in_flight_.front().value <= done) {
    if (const auto& timing = in_flight_.front().timing; timing && !timing->names.empty()) {
      if (KernelProfile* profile = ctx_.kernel_profile()) {
        const double ms_per_tick = double(ctx_.features().timestamp_period_ns) * 1e-6;
        const uint32_t bits = ctx_.features().timestamp_valid_bits;
        const uint64_t mask = bits >= 64 ? ~uint64_t{0} : (uint64_t{1} << bits) - 1;  // counters wrap
        for (size_t p = 0; p < timing->pools.size(); ++p) {
          const size_t first = p * CommandList::Timing::kQueriesPerPool / 2;
          const uint32_t count = 2 * static_cast<uint32_t>(std::min<size_t>(timing->names.size() - first,
                                                                            CommandList::Timing::kQueriesPerPool / 2));
          // The submission has finished, so the results are available.
          const auto [result, ticks] = timing->pools[p].getResults<uint64_t>(
              0, count, count * sizeof(uint64_t), sizeof(uint64_t), vk::QueryResultFlagBits::e64 | vk::QueryResultFlagBits::eWait);
          if (result != vk::Result::eSuccess) continue;
          for (uint32_t q = 0; q < count; q += 2) {
            const std::string& group = timing->groups[first + q / 2];
            profile->add((group.empty() ? profile_group_ : group) + ": " + timing->names[first + q / 2],
                         double((ticks[q + 1] - ticks[q]) & mask) * ms_per_tick);
          }
        }
      }
    }
    recycled_.push_back(std::move(in_flight_.front().cmd));
    in_flight_.pop_front();  // releases the buffers the submission held
  }
}

void Stream::run(const std::function<void(CommandList&)>& record) {
  CommandList list = begin();
  record(list);
  wait(submit(std::move(list)));
}

const BufferPtr& Stream::staging(size_t bytes) {
  if (!staging_ || staging_->size() < bytes) {
    const size_t grown = staging_ ? std::max(bytes, staging_->size() + staging_->size() / 2) : bytes;
    staging_ = Buffer::create(ctx_, grown, name_ + " staging", BufferUsage::Staging);
  }
  return staging_;
}

const void* record_download(Context& ctx, CommandList& cmd, const BufferPtr& src, size_t bytes, size_t src_offset,
                            BufferPtr& readback) {
  if (src_offset + bytes > src->size())
    throw Error("download of " + std::to_string(bytes) + " bytes from '" + src->name() + "' (" + std::to_string(src->size()) +
                " bytes) is out of range");
  if (src->mapped()) return static_cast<const char*>(src->mapped()) + src_offset;
  if (!readback || readback->size() < bytes)
    readback = Buffer::create(ctx, std::max<size_t>(bytes, 4), src->name() + " readback", BufferUsage::Staging);
  cmd.barrier();
  cmd.copy(src, readback, bytes, src_offset, 0);
  return readback->mapped();
}

void record_upload(Context& ctx, CommandList& cmd, const BufferPtr& dst, const void* src, size_t bytes,
                   size_t dst_offset, BufferPtr& staging) {
  if (bytes == 0) return;
  if (dst_offset + bytes > dst->size())
    throw Error("upload of " + std::to_string(bytes) + " bytes into '" + dst->name() + "' (" +
                std::to_string(dst->size()) + " bytes) is out of range");
  if (dst->mapped()) {
    std::memcpy(static_cast<char*>(dst->mapped()) + dst_offset, src, bytes);
    return;
  }
  if (!staging || staging->size() < bytes)
    staging = Buffer::create(ctx, bytes, dst->name() + " staging", BufferUsage::Staging);
  std::memcpy(staging->mapped(), src, bytes);
  cmd.barrier();  // after the list's earlier work on `dst`
  cmd.copy(staging, dst, bytes, 0, dst_offset);
  cmd.barrier();  // before its later work
}

const void* Stream::record_download(CommandList& cmd, const BufferPtr& src, size_t bytes, size_t src_offset) {
  return gpu::record_download(ctx_, cmd, src, bytes, src_offset, readback_);
}

void Stream::upload(const BufferPtr& dst, const void* src, size_t bytes, size_t dst_offset) {
  if (bytes == 0) return;
  wait(upload_submitted(dst, src, bytes, dst_offset));
}

TimelinePoint Stream::upload_submitted(const BufferPtr& dst, const void* src, size_t bytes, size_t dst_offset) {
  if (dst_offset + bytes > dst->size())
    throw Error("upload of " + std::to_string(bytes) + " bytes into '" + dst->name() + "' (" + std::to_string(dst->size()) +
                " bytes) is out of range");
  wait_idle();  // earlier work may still read `dst` or the staging buffer
  if (bytes == 0) return last_submitted();
  if (dst->mapped()) {
    std::memcpy(static_cast<char*>(dst->mapped()) + dst_offset, src, bytes);
    return last_submitted();
  }
  const BufferPtr& staging = this->staging(bytes);
  std::memcpy(staging->mapped(), src, bytes);
  CommandList cmd = begin();
  cmd.copy(staging, dst, bytes, 0, dst_offset);
  return submit(std::move(cmd));
}

void Stream::wait_next_on_gpu(const TimelinePoint& point) {
  if (point.semaphore) next_waits_.push_back(point);
}

void Stream::download(const BufferPtr& src, void* dst, size_t bytes, size_t src_offset) {
  if (bytes == 0) return;
  if (src_offset + bytes > src->size())
    throw Error("download of " + std::to_string(bytes) + " bytes from '" + src->name() + "' (" + std::to_string(src->size()) +
                " bytes) is out of range");
  wait_idle();
  if (src->mapped()) {
    std::memcpy(dst, static_cast<const char*>(src->mapped()) + src_offset, bytes);
    return;
  }
  CommandList cmd = begin();
  const void* host = record_download(cmd, src, bytes, src_offset);
  wait(submit(std::move(cmd)));
  std::memcpy(dst, host, bytes);
}

}  // namespace cofusion::gpu

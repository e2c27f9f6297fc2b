#pragma once
// Recording and submission of compute work.
//
// A Stream is one worker's lane to the GPU: a command pool, the queue the Context hands to that
// worker, and a timeline semaphore. Every submission signals the next timeline value; other
// streams wait on (semaphore, value) points, which is how cross-model dependencies are expressed.
// A CommandList keeps every buffer it references alive (shared_ptr) and the Stream holds the list
// until the GPU has passed its timeline value, so nothing is freed while the GPU may still use it.
//
// Thread safety: a Stream (and its CommandLists) belongs to one thread at a time. Several streams
// may submit concurrently from different threads, also when they share one VkQueue.
#include <cstdint>
#include <deque>
#include <functional>
#include <initializer_list>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "gpu/buffer.h"
#include "gpu/pipeline.h"

namespace cofusion::gpu {

struct TimelinePoint {
  vk::Semaphore semaphore;
  uint64_t value = 0;
};

// Number of workgroups needed to cover `items` with groups of `group_size`.
constexpr uint32_t group_count(uint32_t items, uint32_t group_size) { return (items + group_size - 1) / group_size; }

class CommandList {
 public:
  CommandList(CommandList&&) = default;
  CommandList& operator=(CommandList&&) = default;

  // Binds `buffers` to bindings 0..n-1 of `pipeline`, pushes `push_bytes` of constants and
  // dispatches. A dispatch with zero groups is skipped (empty images are legal inputs).
  void dispatch(const ComputePipeline& pipeline, std::initializer_list<BufferPtr> buffers, const void* push,
                uint32_t push_bytes, uint32_t groups_x, uint32_t groups_y = 1, uint32_t groups_z = 1);
  template <typename Params>
  void dispatch(const ComputePipeline& pipeline, std::initializer_list<BufferPtr> buffers, const Params& params,
                uint32_t groups_x, uint32_t groups_y = 1, uint32_t groups_z = 1) {
    dispatch(pipeline, buffers, &params, sizeof(Params), groups_x, groups_y, groups_z);
  }
  // As dispatch(), with the workgroup counts read by the GPU from `args` (a BufferUsage::Indirect
  // buffer) at `offset` (a VkDispatchIndirectCommand written earlier in this list, then
  // indirect_barrier()). Counts of 0 dispatch nothing.
  void dispatch_indirect(const ComputePipeline& pipeline, std::initializer_list<BufferPtr> buffers, const void* push,
                         uint32_t push_bytes, const BufferPtr& args, size_t offset);
  template <typename Params>
  void dispatch_indirect(const ComputePipeline& pipeline, std::initializer_list<BufferPtr> buffers,
                         const Params& params, const BufferPtr& args, size_t offset) {
    dispatch_indirect(pipeline, buffers, &params, sizeof(Params), args, offset);
  }
  // Makes every earlier compute/transfer write visible to every later compute/transfer access.
  void barrier();
  // barrier(), and also to the indirect dispatches' reads of their workgroup counts.
  void indirect_barrier();
  void copy(const BufferPtr& src, const BufferPtr& dst, size_t bytes, size_t src_offset = 0, size_t dst_offset = 0);
  // Fills the whole buffer with a 32-bit pattern.
  void fill(const BufferPtr& dst, uint32_t value);
  // Fills `bytes` bytes from `offset` (both multiples of 4).
  void fill(const BufferPtr& dst, uint32_t value, size_t offset, size_t bytes);
  // Keeps `object` alive until this list has finished executing.
  void hold(std::shared_ptr<const void> object) { held_.push_back(std::move(object)); }
  // Names the dispatches recorded from now on in the kernel profile ("icp_rgb_reduce 640x480");
  // no effect unless the Context has a profile attached.
  void set_profile_label(const std::string& label);
  // Files the dispatches recorded from now on under `group` in the kernel profile instead of the
  // stream's group (Stream::set_profile_group); empty = the stream's. One list may serve several
  // models (track_together).
  void set_profile_group(const std::string& group);
  // Whether this list's dispatches are timed (callers skip building labels otherwise).
  bool profiled() const { return timing_ != nullptr; }
  vk::CommandBuffer handle() const { return *cmd_; }
  // A profiled list allocates query pools of this many dispatches (two timestamps each) as needed.
  static constexpr uint32_t kProfiledDispatchesPerPool = 128;

 private:
  friend class Stream;
  struct Timing {
    static constexpr uint32_t kQueriesPerPool = 2 * kProfiledDispatchesPerPool;
    const Context* ctx = nullptr;
    std::vector<vk::raii::QueryPool> pools;
    std::vector<std::string> names;   // one per timed dispatch
    std::vector<std::string> groups;  // one per timed dispatch; empty = the stream's
    std::string label;
    std::string group;
  };
  // Throws unless `pipeline` takes `buffer_count` buffers and `push_bytes` of constants.
  static void check(const ComputePipeline& pipeline, size_t buffer_count, uint32_t push_bytes);
  // Binds `buffers` and pushes the constants of a dispatch of `pipeline` (after check()).
  void bind(const ComputePipeline& pipeline, std::initializer_list<BufferPtr> buffers, const void* push,
            uint32_t push_bytes);
  // Records `dispatch` (the vkCmdDispatch*), between two timestamps when the list is profiled.
  template <typename Dispatch>
  void record_timed(const ComputePipeline& pipeline, Dispatch&& dispatch);
  CommandList(vk::raii::CommandBuffer cmd, std::unique_ptr<Timing> timing)
      : cmd_(std::move(cmd)), timing_(std::move(timing)) {}
  vk::raii::CommandBuffer cmd_;
  std::vector<std::shared_ptr<const void>> held_;
  std::unique_ptr<Timing> timing_;
};

// A download recorded into `cmd` after its earlier work: returns where the host finds the `bytes`
// of `src` (from `src_offset`) once the list's submission has completed. That is `src`'s own
// mapping where it has one, else `readback` (a host-visible buffer, created or grown here; named
// after `src`), which the caller keeps until then and which the next such copy overwrites.
const void* record_download(Context& ctx, CommandList& cmd, const BufferPtr& src, size_t bytes, size_t src_offset,
                            BufferPtr& readback);

// An upload recorded into `cmd`: the `bytes` at `src` are copied now, into `dst`'s own mapping
// where it has one (the caller makes sure the GPU is not using `dst` meanwhile), else into
// `staging` (created or grown here), with the copy to `dst` (at `dst_offset`) and a barrier
// recorded into `cmd`; the caller leaves `staging` alone until the list has executed.
void record_upload(Context& ctx, CommandList& cmd, const BufferPtr& dst, const void* src, size_t bytes,
                   size_t dst_offset, BufferPtr& staging);

class Stream {
 public:
  // Uses ctx.queue_for_worker(worker): its own queue where the device has several.
  Stream(Context& ctx, uint32_t worker, const std::string& name);
  ~Stream();
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;

  CommandList begin();
  // Submits `list`, which first waits for every point in `waits`; returns the point that signals
  // when it has finished.
  TimelinePoint submit(CommandList&& list, std::span<const TimelinePoint> waits = {});
  // Returns once `point` is reached: polling first for Context::spin_wait_us(), then asleep in the
  // driver.
  void wait(const TimelinePoint& point);
  void wait_idle();
  uint64_t completed_value() const;
  TimelinePoint last_submitted() const { return {*timeline_, next_value_}; }

  // Record, submit and wait: for synchronous work (tests, set-up, benchmarks).
  void run(const std::function<void(CommandList&)>& record);
  // Synchronous transfers. They first wait for this stream's earlier work; mapped buffers are
  // copied directly, others through this stream's staging (upload) or readback (download) buffer,
  // each kept and grown as needed.
  void upload(const BufferPtr& dst, const void* src, size_t bytes, size_t dst_offset = 0);
  void download(const BufferPtr& src, void* dst, size_t bytes, size_t src_offset = 0);
  // upload() without its wait: returns the point at which `dst` holds the data (the host's copy
  // of `src` is made before it returns; a mapped `dst` holds it at once).
  TimelinePoint upload_submitted(const BufferPtr& dst, const void* src, size_t bytes, size_t dst_offset = 0);
  // The next submission of this stream also waits, on the GPU, for `point` (e.g. another stream's
  // upload_submitted()); a point without a semaphore is ignored.
  void wait_next_on_gpu(const TimelinePoint& point);
  // A download recorded into `cmd` after its earlier work, so one submission computes and reads
  // back: returns where the host finds the `bytes` of `src` (from `src_offset`) once that
  // submission has completed (wait for it). The pointer is `src`'s own mapping where it has one,
  // else this stream's readback buffer, which the next recorded download reuses: one such
  // download in flight per stream.
  const void* record_download(CommandList& cmd, const BufferPtr& src, size_t bytes, size_t src_offset = 0);
  template <typename T>
  void upload(const BufferPtr& dst, std::span<const T> data) {
    upload(dst, data.data(), data.size_bytes());
  }
  template <typename T>
  std::vector<T> download(const BufferPtr& src, size_t count) {
    std::vector<T> out(count);
    download(src, out.data(), count * sizeof(T));
    return out;
  }

  Context& context() const { return ctx_; }
  const std::string& name() const { return name_; }
  const std::string& profile_group() const { return profile_group_; }
  // The group this stream's dispatches are filed under in the kernel profile (default: its name),
  // e.g. "background" or "objects".
  void set_profile_group(const std::string& group) { profile_group_ = group; }

 private:
  struct InFlight {
    uint64_t value;
    vk::raii::CommandBuffer cmd;
    std::vector<std::shared_ptr<const void>> held;
    std::unique_ptr<CommandList::Timing> timing;
  };
  void collect_finished();
  std::vector<TimelinePoint> next_waits_;  // wait_next_on_gpu()
  // Polls the timeline for up to Context::spin_wait_us(); whether `point` was reached.
  bool poll_until_reached(const TimelinePoint& point) const;
  // The upload staging buffer, at least `bytes` large. Only synchronous uploads use it, after waiting
  // for every earlier submission, so one buffer serves them all.
  const BufferPtr& staging(size_t bytes);

  Context& ctx_;
  Queue& queue_;
  std::string name_;
  std::string profile_group_;
  vk::raii::CommandPool pool_{nullptr};
  vk::raii::Semaphore timeline_{nullptr};
  uint64_t next_value_ = 0;
  std::deque<InFlight> in_flight_;
  std::vector<vk::raii::CommandBuffer> recycled_;
  BufferPtr staging_;
  BufferPtr readback_;
};

}  // namespace cofusion::gpu

// The Vulkan compute core: device choice, queues, buffers (mapped and staging), pipelines with
// push constants and push descriptors, timeline-semaphore submission and resource lifetime.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <numeric>
#include <random>
#include <thread>

#include "embedded_shaders.h"
#include "gpu/buffer.h"
#include "gpu/pipeline.h"
#include "gpu/stream.h"
#include "shared/host_device.h"
#include "support/gpu_fixture.h"

namespace cofusion::test {
namespace {
using ::testing::HasSubstr;

class ComputeCore : public GpuTest {
 protected:
  gpu::ComputePipeline fill_pipeline() {
    return gpu::ComputePipeline(ctx(), "test_fill", shaders::test_fill_comp(), 1, sizeof(gpu_layout::TestFillParams));
  }
  void fill(gpu::Stream& s, const gpu::ComputePipeline& p, const gpu::BufferPtr& b, uint32_t count, uint32_t offset) {
    s.run([&](gpu::CommandList& cmd) {
      cmd.dispatch(p, {b}, gpu_layout::TestFillParams{count, offset}, gpu::group_count(count, 64));
    });
  }
};

TEST_F(ComputeCore, DescribesTheChosenDevice) {
  EXPECT_FALSE(ctx().info().name.empty());
  EXPECT_TRUE(ctx().info().usable);
  EXPECT_GE(ctx().compute_queue_count(), 1u);
  EXPECT_THAT(ctx().description(), HasSubstr(ctx().info().name));
  EXPECT_GE(ctx().features().subgroup_size, 1u);
}

TEST_F(ComputeCore, ListsDevicesAndSelectsByIndexAndName) {
  const auto devices = gpu::Context::list_devices();
  ASSERT_FALSE(devices.empty());
  auto by_index = validated_options();
  by_index.device = std::to_string(ctx().info().index);
  EXPECT_EQ(gpu::Context(by_index).info().name, ctx().info().name);
  auto by_name = validated_options();
  by_name.device = ctx().info().name.substr(0, 4);
  EXPECT_EQ(gpu::Context(by_name).info().name.substr(0, 4), by_name.device);
}

TEST_F(ComputeCore, RejectsUnknownDeviceWithReason) {
  auto options = validated_options();
  options.device = "no-such-gpu-xyz";
  try {
    gpu::Context c(options);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("no-such-gpu-xyz"));
  }
  options.device = "99";
  EXPECT_THROW(gpu::Context{options}, Error);
}

TEST_F(ComputeCore, HandsOutOneQueuePerWorkerOrSharesTheOnlyOne) {
  const uint32_t n = ctx().compute_queue_count();
  for (uint32_t w = 0; w < 2 * n; ++w) {
    gpu::Queue& q = ctx().queue_for_worker(w);
    EXPECT_EQ(&q, &ctx().queue_for_worker(w % n));
    if (n > 1 && w > 0 && w < n) {
      EXPECT_NE(&q, &ctx().queue_for_worker(0));
    }
  }
}

TEST_F(ComputeCore, LimitsTheComputeQueuesWhenAsked) {
  auto one = validated_options();
  one.max_compute_queues = 1;
  gpu::Context single(one);
  EXPECT_EQ(single.compute_queue_count(), 1u);
  EXPECT_EQ(&single.queue_for_worker(0), &single.queue_for_worker(3));
  auto all = validated_options();
  all.max_compute_queues = 0;
  EXPECT_EQ(gpu::Context(all).compute_queue_count(), ctx().compute_queue_count());
}

TEST_F(ComputeCore, DispatchWritesEveryElementForEdgeSizes) {
  const auto p = fill_pipeline();
  for (uint32_t count : {1u, 63u, 64u, 65u, 1000u, 640u * 480u}) {
    auto b = gpu::Buffer::create(ctx(), count * 4, "fill target");
    fill(stream(), p, b, count, 7);
    const auto out = stream().download<uint32_t>(b, count);
    for (uint32_t i = 0; i < count; ++i) ASSERT_EQ(out[i], i + 7) << "count " << count << " index " << i;
  }
}

TEST_F(ComputeCore, KernelProfileTimesEveryDispatchUnderItsGroupAndLabel) {
  gpu::Context c(validated_options());
  auto profile = std::make_shared<gpu::KernelProfile>();
  if (c.features().timestamp_valid_bits == 0) {
    EXPECT_THROW(c.set_kernel_profile(profile), Error);
    return;
  }
  c.set_kernel_profile(profile);
  gpu::ComputePipeline p(c, "test_fill", shaders::test_fill_comp(), 1, sizeof(gpu_layout::TestFillParams));
  gpu::Stream s(c, 0, "profiled stream");
  s.set_profile_group("group");
  const uint32_t count = 640 * 480;
  auto b = gpu::Buffer::create(c, count * 4, "fill target");
  // More dispatches than one query pool holds, then a labelled one.
  const uint32_t unlabelled = 3 * gpu::CommandList::kProfiledDispatchesPerPool / 2;
  s.run([&](gpu::CommandList& cmd) {
    for (uint32_t i = 0; i < unlabelled; ++i) {
      cmd.dispatch(p, {b}, gpu_layout::TestFillParams{count, i}, gpu::group_count(count, 64));
      cmd.barrier();
    }
    cmd.set_profile_label("labelled");
    cmd.dispatch(p, {b}, gpu_layout::TestFillParams{count, 5}, gpu::group_count(count, 64));
  });
  const auto entries = profile->take();
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_EQ(entries.at("group: test_fill").calls, unlabelled);
  EXPECT_GT(entries.at("group: test_fill").total_ms, 0.0);
  EXPECT_EQ(entries.at("group: test_fill labelled").calls, 1u);
  EXPECT_GT(entries.at("group: test_fill labelled").total_ms, 0.0);
  EXPECT_TRUE(profile->take().empty());
  const auto out = s.download<uint32_t>(b, count);
  EXPECT_EQ(out[count - 1], count - 1 + 5);  // timing does not change the work

  c.set_kernel_profile(nullptr);
  s.run([&](gpu::CommandList& cmd) { cmd.dispatch(p, {b}, gpu_layout::TestFillParams{count, 0}, gpu::group_count(count, 64)); });
  EXPECT_TRUE(profile->take().empty());
}

// Texel-view reads (shared/texel_access.glsl) return every word bit for bit, NaN and infinity
// patterns included, for buffer sizes that are not whole texels and with the staging path.
TEST_F(ComputeCore, TexelViewReadsMatchTheStoredWordsForEdgeSizes) {
  gpu::ComputePipeline p(ctx(), "test_texel_read", shaders::test_texel_read_comp(), 2, sizeof(gpu_layout::TestTexelParams),
                         1u << TEST_TEXEL_BINDING_SRC);
  std::mt19937 rng(7);
  for (uint32_t words : {1u, 3u, 4u, 5u, 12u, 63u, 1000u, 24u * 1001u, 640u * 480u + 1u}) {
    std::vector<uint32_t> in(words);
    for (auto& w : in) w = rng();
    in[0] = 0x7FC00001u;  // a NaN with a payload
    if (words > 1) in[1] = 0xFF800000u;  // -infinity
    auto src = gpu::Buffer::create(ctx(), words * 4, "texel source");
    auto dst = gpu::Buffer::create(ctx(), words * 4, "texel copy");
    stream().upload(src, in.data(), words * 4);
    for (uint32_t mode = 0; mode <= 5; ++mode) {
      const uint32_t per_element = mode == 2 || mode == 4 ? 2 : mode == 3 ? 4 : mode == 5 ? 12 : 1;
      const uint32_t n = words / per_element * per_element;  // whole elements only
      if (n == 0) continue;
      stream().run([&](gpu::CommandList& cmd) {
        cmd.dispatch(p, {src, dst}, gpu_layout::TestTexelParams{n, mode}, gpu::group_count(n, 64));
      });
      const auto out = stream().download<uint32_t>(dst, n);
      for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(out[i], in[i]) << "words " << words << " mode " << mode << " word " << i;
    }
  }
  EXPECT_THROW(gpu::ComputePipeline(ctx(), "test_texel_read", shaders::test_texel_read_comp(), 2,
                                    sizeof(gpu_layout::TestTexelParams), 1u << 2),
               Error);  // a texel binding beyond the pipeline's bindings
  auto staging = gpu::Buffer::create(ctx(), 64, "a staging buffer", gpu::BufferUsage::Staging);
  try {
    staging->texel_view();
    FAIL() << "a staging buffer has no texel view";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("a staging buffer"));
  }
}

TEST_F(ComputeCore, ZeroSizedDispatchIsSkipped) {
  const auto p = fill_pipeline();
  auto b = gpu::Buffer::create(ctx(), 0, "empty");
  EXPECT_EQ(b->size(), 4u);  // rounded up: Vulkan has no empty buffers
  stream().run([&](gpu::CommandList& cmd) { cmd.dispatch(p, {b}, gpu_layout::TestFillParams{0, 0}, 0); });
}

TEST_F(ComputeCore, RejectsWrongBindingOrParameterCount) {
  const auto p = fill_pipeline();
  auto b = gpu::Buffer::create(ctx(), 16, "b");
  auto cmd = stream().begin();
  EXPECT_THROW(cmd.dispatch(p, {b, b}, gpu_layout::TestFillParams{4, 0}, 1), Error);
  EXPECT_THROW(cmd.dispatch(p, {b}, uint32_t{4}, 1), Error);
  stream().submit(std::move(cmd));
}

TEST_F(ComputeCore, UploadAndDownloadRoundTripThroughMappingAndStaging) {
  std::vector<float> data(12345);
  std::iota(data.begin(), data.end(), 0.5f);
  auto b = gpu::Buffer::create(ctx(), data.size() * 4, "round trip");
  EXPECT_EQ(b->mapped() != nullptr, ctx().features().device_local_memory_is_host_cached);
  stream().upload<float>(b, data);
  EXPECT_EQ(stream().download<float>(b, data.size()), data);

  gpu::Context staging_ctx(staging_options());
  gpu::Stream s(staging_ctx, 0, "staging stream");
  auto sb = gpu::Buffer::create(staging_ctx, data.size() * 4, "staged");
  EXPECT_EQ(sb->mapped(), nullptr);
  s.upload<float>(sb, data);
  EXPECT_EQ(s.download<float>(sb, data.size()), data);
  // And a kernel result read back through staging.
  gpu::ComputePipeline p(staging_ctx, "test_fill", shaders::test_fill_comp(), 1, sizeof(gpu_layout::TestFillParams));
  fill(s, p, sb, 100, 1);
  const auto out = s.download<uint32_t>(sb, 100);
  EXPECT_EQ(out[99], 100u);
  EXPECT_EQ(staging_ctx.validation_error_count(), 0u);
}

// A kernel's result read back in the submission that computes it: mapped (lavapipe) and through
// the readback buffer (as on discrete GPUs), for edge sizes and an offset.
TEST_F(ComputeCore, RecordedDownloadReadsTheResultOfItsOwnSubmission) {
  gpu::Context staging_ctx(staging_options());
  for (gpu::Context* c : {&ctx(), &staging_ctx}) {
    SCOPED_TRACE(c == &ctx() ? "fixture context" : "staging context");
    gpu::Stream s(*c, 0, "recorded download");
    gpu::ComputePipeline p(*c, "test_fill", shaders::test_fill_comp(), 1, sizeof(gpu_layout::TestFillParams));
    for (uint32_t count : {1u, 63u, 64u, 65u, 1000u}) {
      auto b = gpu::Buffer::create(*c, (count + 3) * 4, "filled");
      auto cmd = s.begin();
      cmd.dispatch(p, {b}, gpu_layout::TestFillParams{count + 3, 5}, gpu::group_count(count + 3, 64));
      const auto* host = static_cast<const uint32_t*>(s.record_download(cmd, b, count * 4, 3 * 4));
      s.wait(s.submit(std::move(cmd)));
      std::vector<uint32_t> expected(count);
      std::iota(expected.begin(), expected.end(), 8u);
      EXPECT_EQ(std::vector<uint32_t>(host, host + count), expected) << count << " elements";
    }
    auto cmd = s.begin();
    auto small = gpu::Buffer::create(*c, 16, "small readback source");
    EXPECT_THAT([&] { s.record_download(cmd, small, 16, 4); },
                ThrowsMessage<Error>(HasSubstr("small readback source")));
  }
  EXPECT_EQ(staging_ctx.validation_error_count(), 0u);
}

// gpu::record_upload: the data is copied at once (into the buffer's mapping or a staging buffer)
// and the list's own later work sees it; a staging buffer is grown as needed and reused by the
// next list once the earlier one has completed.
TEST_F(ComputeCore, RecordedUploadIsSeenByTheListsOwnWork) {
  gpu::Context staging_ctx(staging_options());
  for (gpu::Context* c : {&ctx(), &staging_ctx}) {
    SCOPED_TRACE(c == &ctx() ? "fixture context" : "staging context");
    gpu::Stream s(*c, 0, "recorded upload");
    gpu::BufferPtr staging;  // kept between lists, as the frame's inputs keep theirs
    for (uint32_t count : {1u, 63u, 64u, 65u, 1000u, 7u}) {
      std::vector<uint32_t> data(count);
      std::iota(data.begin(), data.end(), count);
      auto dst = gpu::Buffer::create(*c, (count + 3) * 4, "upload target");
      auto copy = gpu::Buffer::create(*c, count * 4, "copy of the upload");
      auto cmd = s.begin();
      gpu::record_upload(*c, cmd, dst, data.data(), count * 4, 3 * 4, staging);
      data.assign(count, 0);  // the caller's memory may change once the call returns
      cmd.barrier();
      cmd.copy(dst, copy, count * 4, 3 * 4, 0);
      const auto* host = static_cast<const uint32_t*>(s.record_download(cmd, copy, count * 4));
      s.wait(s.submit(std::move(cmd)));
      std::vector<uint32_t> expected(count);
      std::iota(expected.begin(), expected.end(), count);
      EXPECT_EQ(std::vector<uint32_t>(host, host + count), expected) << count << " elements";
    }
    auto cmd = s.begin();
    auto small = gpu::Buffer::create(*c, 16, "small upload target");
    const std::vector<uint8_t> big(16);
    EXPECT_THAT([&] { gpu::record_upload(*c, cmd, small, big.data(), 16, 4, staging); },
                ThrowsMessage<Error>(HasSubstr("small upload target")));
  }
  EXPECT_EQ(staging_ctx.validation_error_count(), 0u);
}

TEST_F(ComputeCore, OutOfRangeTransfersAndHugeBuffersFailWithTheirNames) {
  auto b = gpu::Buffer::create(ctx(), 16, "small buffer");
  std::vector<uint8_t> big(64);
  try {
    stream().upload(b, big.data(), big.size());
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("small buffer"));
  }
  try {
    gpu::Buffer::create(ctx(), size_t{1} << 50, "enormous model");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("enormous model"));
  }
}

// The context counts the device memory its buffers hold (`cofusion bench --soak` reports it).
TEST_F(ComputeCore, CountsTheDeviceMemoryOfLiveBuffers) {
  stream().wait_idle();
  stream().begin();  // finished submissions release the buffers they held
  const uint64_t bytes = ctx().allocated_device_bytes(), allocations = ctx().live_device_allocations();
  {
    auto a = gpu::Buffer::create(ctx(), 1 << 20, "counted 1 MiB");
    auto b = gpu::Buffer::create(ctx(), 100, "counted 100 bytes", gpu::BufferUsage::Staging);
    EXPECT_EQ(ctx().live_device_allocations(), allocations + 2);
    EXPECT_GE(ctx().allocated_device_bytes(), bytes + (1 << 20) + 100);
    EXPECT_LE(ctx().allocated_device_bytes(), bytes + (1 << 20) + 100 + 2 * 65536) << "at most alignment on top";
  }
  EXPECT_EQ(ctx().allocated_device_bytes(), bytes);
  EXPECT_EQ(ctx().live_device_allocations(), allocations);
  try {
    gpu::Buffer::create(ctx(), size_t{1} << 50, "enormous model");
  } catch (const Error&) {
  }
  EXPECT_EQ(ctx().allocated_device_bytes(), bytes) << "a buffer that failed holds nothing";
}

TEST_F(ComputeCore, BuffersHaveDeviceAddressesWhereSupported) {
  auto b = gpu::Buffer::create(ctx(), 256, "addressed");
  if (!ctx().features().buffer_device_address) GTEST_SKIP() << "device has no buffer device address";
  EXPECT_NE(b->device_address(), 0u);
}

TEST_F(ComputeCore, TimelineWaitOrdersWorkAcrossStreams) {
  // Stream B copies what stream A wrote; B's submission waits for A's timeline point.
  const auto p = fill_pipeline();
  gpu::Stream a(ctx(), 0, "stream A"), b(ctx(), 1, "stream B");
  const uint32_t n = 4096;
  auto src = gpu::Buffer::create(ctx(), n * 4, "src"), dst = gpu::Buffer::create(ctx(), n * 4, "dst");
  auto cmd_a = a.begin();
  cmd_a.dispatch(p, {src}, gpu_layout::TestFillParams{n, 3}, gpu::group_count(n, 64));
  const gpu::TimelinePoint done_a = a.submit(std::move(cmd_a));
  auto cmd_b = b.begin();
  cmd_b.copy(src, dst, n * 4);
  const gpu::TimelinePoint waits[] = {done_a};
  const gpu::TimelinePoint done_b = b.submit(std::move(cmd_b), waits);
  b.wait(done_b);
  EXPECT_GE(a.completed_value(), done_a.value);
  const auto out = b.download<uint32_t>(dst, n);
  for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(out[i], i + 3);
}

// Lavapipe runs a dispatch's workgroups on one thread per CPU unless LP_NUM_THREADS holds a
// number; the context reports what this process's environment gives.
TEST(LavapipeThreads, FollowTheCpusUnlessLpNumThreadsHoldsANumber) {
  const uint32_t cpus = std::max(1u, std::thread::hardware_concurrency());
  EXPECT_EQ(gpu::lavapipe_threads(nullptr), cpus);
  EXPECT_EQ(gpu::lavapipe_threads(""), cpus);
  EXPECT_EQ(gpu::lavapipe_threads("3"), 3u);
  EXPECT_EQ(gpu::lavapipe_threads("0"), 1u);  // lavapipe's "in the calling thread"
  EXPECT_EQ(gpu::lavapipe_threads("3x"), cpus);
  EXPECT_EQ(gpu::lavapipe_threads("-2"), cpus);
  EXPECT_EQ(gpu::lavapipe_threads("many"), cpus);
}

TEST_F(ComputeCore, ReportsTheThreadsOfASoftwareDevice) {
  EXPECT_EQ(ctx().software_threads(), gpu::lavapipe_threads(std::getenv("LP_NUM_THREADS")));
}

// Waits that poll the timeline first (ContextOptions::spin_wait_us; by device: none where the
// device is the CPU or the host has few threads) return only once the work is done, whether the polling sees it finish or
// runs out and the driver's wait takes over.
TEST_F(ComputeCore, WaitsThatPollFirstReturnOnlyOnceTheWorkIsDone) {
  const bool by_default = !ctx().is_software() && std::thread::hardware_concurrency() >= gpu::Context::kMinThreadsToSpin;
  EXPECT_EQ(ctx().spin_wait_us(), by_default ? gpu::Context::kDefaultSpinWaitUs : 0u);
  for (int spin_us : {1, 200000}) {
    auto options = validated_options();
    options.spin_wait_us = spin_us;
    gpu::Context c(options);
    EXPECT_EQ(c.spin_wait_us(), uint32_t(spin_us));
    EXPECT_THAT(c.description(), HasSubstr("waits poll up to " + std::to_string(spin_us) + " us"));
    gpu::ComputePipeline p(c, "test_fill", shaders::test_fill_comp(), 1, sizeof(gpu_layout::TestFillParams));
    gpu::Stream s(c, 0, "polling waits");
    const uint32_t n = 640 * 480;
    auto b = gpu::Buffer::create(c, n * 4, "polled");
    for (uint32_t round = 0; round < 3; ++round) {
      auto cmd = s.begin();
      cmd.dispatch(p, {b}, gpu_layout::TestFillParams{n, round}, gpu::group_count(n, 64));
      const auto* host = static_cast<const uint32_t*>(s.record_download(cmd, b, n * 4, 0));
      const gpu::TimelinePoint done = s.submit(std::move(cmd));
      s.wait(done);
      EXPECT_GE(s.completed_value(), done.value);
      EXPECT_EQ(host[0], round) << spin_us << " us, round " << round;
      EXPECT_EQ(host[n - 1], n - 1 + round) << spin_us << " us, round " << round;
    }
    EXPECT_EQ(c.validation_error_count(), 0u);
  }
}

// Stream::upload_submitted returns without waiting; another stream's next submission waits for it
// on the GPU (wait_next_on_gpu) and sees the data, through a staging buffer and mapped alike.
TEST_F(ComputeCore, AnUploadWithoutWaitIsSeenByTheStreamThatWaitsForItOnTheGpu) {
  gpu::Context staging_ctx(staging_options());
  for (gpu::Context* c : {&ctx(), &staging_ctx}) {
    SCOPED_TRACE(c == &ctx() ? "fixture context" : "staging context");
    gpu::Stream a(*c, 0, "uploading"), b(*c, 1, "reading");
    const uint32_t n = 640 * 480;
    auto labels = gpu::Buffer::create(*c, n * 4, "labels"), copy = gpu::Buffer::create(*c, n * 4, "copy");
    for (uint32_t round = 0; round < 3; ++round) {
      std::vector<uint32_t> data(n);
      std::iota(data.begin(), data.end(), round * 7);
      const gpu::TimelinePoint uploaded = a.upload_submitted(labels, data.data(), n * 4);
      data.assign(n, 0);  // the host's copy was made before upload_submitted returned
      b.wait_next_on_gpu(uploaded);
      b.run([&](gpu::CommandList& cmd) { cmd.copy(labels, copy, n * 4); });
      const auto out = b.download<uint32_t>(copy, n);
      EXPECT_EQ(out[0], round * 7) << "round " << round;
      EXPECT_EQ(out[n - 1], n - 1 + round * 7) << "round " << round;
    }
    EXPECT_THAT([&] { a.upload_submitted(labels, nullptr, n * 4 + 4); }, ThrowsMessage<Error>(HasSubstr("labels")));
    b.wait_next_on_gpu({});  // no semaphore: ignored
    b.run([](gpu::CommandList&) {});
  }
  EXPECT_EQ(staging_ctx.validation_error_count(), 0u);
}

// wait_next_on_gpu holds the next submission (and only that one) until the point is reached: a
// point not yet signalled (here by the host, as a single queue would otherwise be blocked by the
// waiting submission itself) keeps the submission from completing until it is.
TEST_F(ComputeCore, TheNextSubmissionWaitsOnTheGpuForThePointItWasGiven) {
  vk::SemaphoreTypeCreateInfo type{.semaphoreType = vk::SemaphoreType::eTimeline, .initialValue = 0};
  vk::raii::Semaphore gate(ctx().device(), vk::SemaphoreCreateInfo{.pNext = &type});
  gpu::Stream s(ctx(), 0, "held");
  s.wait_next_on_gpu({*gate, 1});
  const gpu::TimelinePoint held = s.submit(s.begin());
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_LT(s.completed_value(), held.value) << "the submission did not wait for the point";
  ctx().device().signalSemaphore(vk::SemaphoreSignalInfo{.semaphore = *gate, .value = 1});
  s.wait(held);
  const gpu::TimelinePoint after = s.submit(s.begin());  // the wait was for one submission only
  s.wait(after);
  EXPECT_GE(s.completed_value(), after.value);
}

TEST_F(ComputeCore, ASubmissionKeepsItsBuffersAliveUntilItFinishes) {
  const auto p = fill_pipeline();
  std::weak_ptr<gpu::Buffer> watch;
  {
    auto b = gpu::Buffer::create(ctx(), 1 << 20, "transient");
    watch = b;
    auto cmd = stream().begin();
    cmd.dispatch(p, {b}, gpu_layout::TestFillParams{1 << 18, 0}, gpu::group_count(1 << 18, 64));
    stream().submit(std::move(cmd));
  }  // our reference is gone; the submission still holds one until it completes
  stream().wait_idle();
  stream().begin();  // begin() collects finished submissions
  EXPECT_TRUE(watch.expired());
}

TEST_F(ComputeCore, StreamsSubmitConcurrentlyFromSeveralThreads) {
  const auto p = fill_pipeline();
  std::vector<std::thread> workers;
  std::vector<std::vector<uint32_t>> results(4);
  for (uint32_t w = 0; w < 4; ++w)
    workers.emplace_back([&, w] {
      gpu::Stream s(ctx(), w, "worker " + std::to_string(w));
      auto b = gpu::Buffer::create(ctx(), 1024 * 4, "worker buffer");
      for (int rep = 0; rep < 5; ++rep) fill(s, p, b, 1024, w * 10000 + rep);
      results[w] = s.download<uint32_t>(b, 1024);
    });
  for (auto& t : workers) t.join();
  for (uint32_t w = 0; w < 4; ++w) EXPECT_EQ(results[w][5], w * 10000 + 4 + 5);
}

TEST(ValidationMessenger, ReportsErrorsToTheHandler) {
  // A deliberately invalid call (a buffer of size 0) must reach the handler, proving that the
  // messenger the tests rely on is live.
  std::vector<std::string> seen;
  gpu::ContextOptions options;
  options.validation = true;
  options.on_validation_error = [&](const std::string& m) { seen.push_back(m); };
  gpu::Context c(options);
  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = 0;
  info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  VkBuffer buffer = VK_NULL_HANDLE;
  const VkResult r = c.device().getDispatcher()->vkCreateBuffer(*c.device(), &info, nullptr, &buffer);
  if (r == VK_SUCCESS && buffer) c.device().getDispatcher()->vkDestroyBuffer(*c.device(), buffer, nullptr);
  EXPECT_GE(c.validation_error_count(), 1u);
  ASSERT_FALSE(seen.empty());
  EXPECT_THAT(seen[0], HasSubstr("size"));
}

}  // namespace
}  // namespace cofusion::test

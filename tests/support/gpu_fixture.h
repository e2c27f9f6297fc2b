#pragma once
// Base fixture for tests that use the Vulkan device. Validation layers are always on; a
// validation message of error severity fails the current test (ADD_FAILURE from the messenger,
// which runs synchronously on the thread that made the offending call).
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "gpu/context.h"
#include "gpu/stream.h"

namespace cofusion::test {

// Options every test context uses: validation on, errors become test failures.
gpu::ContextOptions validated_options();
// validated_options() whose buffers are never host-mapped: every transfer goes through staging
// buffers, as on discrete GPUs (lavapipe maps every buffer).
gpu::ContextOptions staging_options();

class GpuTest : public ::testing::Test {
 protected:
  // One context per test suite: creating a device with validation costs a noticeable fraction
  // of a second on lavapipe.
  static void SetUpTestSuite();
  static void TearDownTestSuite();
  void SetUp() override;
  void TearDown() override;

  gpu::Context& ctx() { return *context_; }
  gpu::Stream& stream() { return *stream_; }

  // A device buffer holding `v` (at least one element's size, so empty inputs are valid too).
  template <typename T>
  gpu::BufferPtr upload(const std::vector<T>& v, const std::string& what = "input") {
    auto b = gpu::Buffer::create(ctx(), std::max<size_t>(v.size(), 1) * sizeof(T), what);
    stream().upload(b, v.data(), v.size() * sizeof(T));
    return b;
  }

 private:
  static std::unique_ptr<gpu::Context> context_;
  static std::unique_ptr<gpu::Stream> stream_;
  size_t errors_at_start_ = 0;
};

}  // namespace cofusion::test

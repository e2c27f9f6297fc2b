#include "support/gpu_fixture.h"

namespace cofusion::test {

std::unique_ptr<gpu::Context> GpuTest::context_;
std::unique_ptr<gpu::Stream> GpuTest::stream_;

gpu::ContextOptions validated_options() {
  gpu::ContextOptions options;
  options.validation = true;
  options.on_validation_error = [](const std::string& message) { ADD_FAILURE() << "Vulkan validation error: " << message; };
  return options;
}

gpu::ContextOptions staging_options() {
  gpu::ContextOptions options = validated_options();
  options.force_staging = true;
  return options;
}

void GpuTest::SetUpTestSuite() {
  if (!context_) {
    context_ = std::make_unique<gpu::Context>(validated_options());
    stream_ = std::make_unique<gpu::Stream>(*context_, 0, "test stream");
  }
}

void GpuTest::TearDownTestSuite() {
  stream_.reset();
  context_.reset();
}

void GpuTest::SetUp() { errors_at_start_ = context_->validation_error_count(); }

void GpuTest::TearDown() {
  stream_->wait_idle();
  EXPECT_EQ(context_->validation_error_count(), errors_at_start_) << "validation errors during this test";
}

}  // namespace cofusion::test

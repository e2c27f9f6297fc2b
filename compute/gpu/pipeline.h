#pragma once
// A compute pipeline built from embedded SPIR-V. Every binding is a buffer in set 0, bound per
// dispatch with push descriptors (no descriptor pools to manage): a storage buffer, or, for the
// bindings in texel_bindings, a read-only uniform texel buffer of RGBA32UI texels
// (Buffer::texel_view). Parameters travel as push constants.
#include <cstdint>
#include <span>
#include <string>

#include "gpu/context.h"

namespace cofusion::gpu {

class ComputePipeline {
 public:
  ComputePipeline(Context& ctx, const std::string& name, std::span<const uint32_t> spirv, uint32_t binding_count,
                  uint32_t push_constant_bytes, uint32_t texel_bindings = 0);
  ComputePipeline(ComputePipeline&&) = default;

  const std::string& name() const { return name_; }
  vk::Pipeline handle() const { return *pipeline_; }
  vk::PipelineLayout layout() const { return *layout_; }
  uint32_t binding_count() const { return binding_count_; }
  uint32_t push_constant_bytes() const { return push_constant_bytes_; }
  bool is_texel_binding(uint32_t binding) const { return (texel_bindings_ >> binding) & 1u; }

 private:
  std::string name_;
  uint32_t binding_count_ = 0;
  uint32_t push_constant_bytes_ = 0;
  uint32_t texel_bindings_ = 0;  // bit b: binding b is a uniform texel buffer
  vk::raii::DescriptorSetLayout set_layout_{nullptr};
  vk::raii::PipelineLayout layout_{nullptr};
  vk::raii::Pipeline pipeline_{nullptr};
};

}  // namespace cofusion::gpu

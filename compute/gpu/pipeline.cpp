#include "gpu/pipeline.h"

#include <vector>

namespace cofusion::gpu {

ComputePipeline::ComputePipeline(Context& ctx, const std::string& name, std::span<const uint32_t> spirv,
                                 uint32_t binding_count, uint32_t push_constant_bytes, uint32_t texel_bindings)
    : name_(name), binding_count_(binding_count), push_constant_bytes_(push_constant_bytes), texel_bindings_(texel_bindings) {
  if (spirv.empty()) throw Error("compute pipeline '" + name + "': empty SPIR-V");
  if (binding_count < 32 && (texel_bindings >> binding_count) != 0)
    throw Error("compute pipeline '" + name + "': texel bindings beyond its " + std::to_string(binding_count) + " bindings");
  std::vector<vk::DescriptorSetLayoutBinding> bindings;
  for (uint32_t b = 0; b < binding_count; ++b)
    bindings.push_back({.binding = b,
                        .descriptorType = is_texel_binding(b) ? vk::DescriptorType::eUniformTexelBuffer
                                                              : vk::DescriptorType::eStorageBuffer,
                        .descriptorCount = 1,
                        .stageFlags = vk::ShaderStageFlagBits::eCompute});
  set_layout_ = vk::raii::DescriptorSetLayout(
      ctx.device(), vk::DescriptorSetLayoutCreateInfo{.flags = vk::DescriptorSetLayoutCreateFlagBits::ePushDescriptorKHR,
                                                      .bindingCount = binding_count,
                                                      .pBindings = bindings.data()});
  ctx.set_name(set_layout_, name + " set layout");
  vk::PushConstantRange range{.stageFlags = vk::ShaderStageFlagBits::eCompute, .offset = 0, .size = push_constant_bytes};
  vk::DescriptorSetLayout set_layout = *set_layout_;
  layout_ = vk::raii::PipelineLayout(ctx.device(),
                                     vk::PipelineLayoutCreateInfo{.setLayoutCount = 1,
                                                                  .pSetLayouts = &set_layout,
                                                                  .pushConstantRangeCount = push_constant_bytes ? 1u : 0u,
                                                                  .pPushConstantRanges = &range});
  ctx.set_name(layout_, name + " layout");

  vk::raii::ShaderModule module(ctx.device(),
                                vk::ShaderModuleCreateInfo{.codeSize = spirv.size_bytes(), .pCode = spirv.data()});
  ctx.set_name(module, name);
  vk::ComputePipelineCreateInfo info{
      .stage = {.stage = vk::ShaderStageFlagBits::eCompute, .module = *module, .pName = "main"},
      .layout = *layout_};
  pipeline_ = vk::raii::Pipeline(ctx.device(), nullptr, info);
  ctx.set_name(pipeline_, name);
}

}  // namespace cofusion::gpu

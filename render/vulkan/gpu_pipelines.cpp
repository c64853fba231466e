// The two compute pipelines (closest hit, any hit) from SPIR-V compiled into the library at
// build time (glslc -O --target-env=vulkan1.1; render/vulkan/CMakeLists.txt): no shader files
// at run time.
#include <cstdint>

#include "render/vulkan/vulkan_internal.hpp"

namespace rayline::gpu::detail {

namespace {

const std::uint32_t kClosestSpv[] =
#include "traverse_closest.spv.h"
    ;
const std::uint32_t kAnySpv[] =
#include "traverse_any.spv.h"
    ;

VkPipeline make_pipeline(Core& core, const std::uint32_t* code, std::size_t bytes) {
  VkShaderModuleCreateInfo mi{};
  mi.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  mi.codeSize = bytes;
  mi.pCode = code;
  VkShaderModule module = VK_NULL_HANDLE;
  check(vkCreateShaderModule(core.device, &mi, nullptr, &module), "vkCreateShaderModule", &core);
  VkComputePipelineCreateInfo pi{};
  pi.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  pi.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  pi.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  pi.stage.module = module;
  pi.stage.pName = "main";
  pi.layout = core.pipelines.layout;
  VkPipeline p = VK_NULL_HANDLE;
  const VkResult r = vkCreateComputePipelines(core.device, VK_NULL_HANDLE, 1, &pi, nullptr, &p);
  vkDestroyShaderModule(core.device, module, nullptr);
  check(r, "vkCreateComputePipelines", &core);
  return p;
}

}  // namespace

void create_pipelines(Core& core) {
  VkDescriptorSetLayoutBinding b[4]{};
  for (std::uint32_t i = 0; i < 4; ++i) {
    b[i].binding = i;  // nodes, triangles, rays, output
    b[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    b[i].descriptorCount = 1;
    b[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo li{};
  li.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  li.bindingCount = 4;
  li.pBindings = b;
  check(vkCreateDescriptorSetLayout(core.device, &li, nullptr, &core.pipelines.set_layout),
        "vkCreateDescriptorSetLayout", &core);
  VkPushConstantRange pc{};
  pc.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  pc.offset = 0;
  pc.size = 12;  // ray_count, node_count, root
  VkPipelineLayoutCreateInfo pl{};
  pl.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  pl.setLayoutCount = 1;
  pl.pSetLayouts = &core.pipelines.set_layout;
  pl.pushConstantRangeCount = 1;
  pl.pPushConstantRanges = &pc;
  check(vkCreatePipelineLayout(core.device, &pl, nullptr, &core.pipelines.layout), "vkCreatePipelineLayout", &core);
  core.pipelines.closest = make_pipeline(core, kClosestSpv, sizeof(kClosestSpv));
  core.pipelines.any = make_pipeline(core, kAnySpv, sizeof(kAnySpv));
}

void destroy_pipelines(Core& core) {
  auto& p = core.pipelines;
  if (p.closest) vkDestroyPipeline(core.device, p.closest, nullptr);
  if (p.any) vkDestroyPipeline(core.device, p.any, nullptr);
  if (p.layout) vkDestroyPipelineLayout(core.device, p.layout, nullptr);
  if (p.set_layout) vkDestroyDescriptorSetLayout(core.device, p.set_layout, nullptr);
  p = Pipelines{};
}

}  // namespace rayline::gpu::detail

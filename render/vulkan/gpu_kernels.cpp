// Blocks and ray queues in GPU memory and the two traversal dispatches (gpu_kernels.hpp):
// the RAM->GPU T-job (upload_block, upload_rays) and the E-jobs RayIntersect /
// ShadowIntersect (Son & Yoon 2017, Sec. 3.1) on whole ray queues.
#include "render/vulkan/gpu_kernels.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>

#include "render/vulkan/gpu_bvh.hpp"
#include "render/vulkan/vulkan_internal.hpp"

namespace rayline::gpu {

using detail::Buffer;
using detail::check;
using detail::Core;
using detail::Mem;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr std::uint32_t kLocalSize = 64;  // traverse.comp's local_size_x
constexpr VkBufferUsageFlags kData = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;

class BlockImpl final : public GpuBlock {
 public:
  std::uint64_t triangles() const override { return n; }
  std::uint64_t device_bytes() const override { return data.size; }

  std::shared_ptr<Core> core;  // declared first: destroyed after the buffers
  Buffer data;  // one allocation: the nodes, then the triangles at `tri_offset`
  std::uint64_t node_bytes = 0, tri_offset = 0, tri_bytes = 0;
  std::uint64_t n = 0;
  std::uint32_t node_count = 0;
  std::uint32_t root = 0;
};

class RaysImpl final : public GpuRays {
 public:
  std::uint64_t size() const override { return n; }
  std::uint64_t device_bytes() const override { return rays.size; }

  std::shared_ptr<Core> core;
  Buffer rays;
  std::uint64_t n = 0;
};

std::string mib(std::uint64_t b) { return std::to_string((b + (1u << 20) - 1) >> 20) + " MiB"; }

// A kernel binding must fit in maxStorageBufferRange (128 MiB on lavapipe, 4 GiB on
// NVIDIA): a block whose array does not cannot be traversed on this device.
void check_binding(const Core& core, std::uint64_t bytes, const char* what, std::uint64_t triangles) {
  const std::uint64_t limit = core.props.limits.maxStorageBufferRange;
  if (bytes > limit)
    throw GpuError(GpuErrorKind::OutOfMemory,
                   "GPU: a block of " + std::to_string(triangles) + " triangles needs " + mib(bytes) + " of " + what +
                       ", more than one storage binding holds on '" + core.info.name + "' (maxStorageBufferRange " +
                       mib(limit) + ")");
}

Buffer upload_array(Core& core, const void* data, std::uint64_t bytes) {
  Buffer b = detail::make_buffer(core, bytes, kData, Mem::Device, true);
  detail::write_buffer(core, b, data, bytes);
  return b;
}

// Grows a slot's scratch buffer to at least `bytes`.
void ensure_scratch(Core& core, Buffer& b, std::uint64_t bytes, VkBufferUsageFlags usage, Mem mem) {
  if (b && b.size >= bytes) return;
  if (b) core.scratch_bytes -= b.size;
  b.reset();
  const std::uint64_t want = std::max<std::uint64_t>(bytes, 1 << 16);
  b = detail::make_buffer(core, want, usage, mem, false);
  core.scratch_bytes += want;
}

void ensure_descriptors(Core& core, detail::Slot& s, std::uint32_t sets) {
  if (s.descriptors && s.descriptor_sets >= sets) {
    check(vkResetDescriptorPool(core.device, s.descriptors, 0), "vkResetDescriptorPool", &core);
    return;
  }
  if (s.descriptors) vkDestroyDescriptorPool(core.device, s.descriptors, nullptr);
  s.descriptors = VK_NULL_HANDLE;
  const std::uint32_t cap = std::max<std::uint32_t>(sets, 4);
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 4 * cap};
  VkDescriptorPoolCreateInfo pi{};
  pi.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  pi.maxSets = cap;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = &size;
  check(vkCreateDescriptorPool(core.device, &pi, nullptr, &s.descriptors), "vkCreateDescriptorPool", &core);
  s.descriptor_sets = cap;
}

void barrier(VkCommandBuffer cmd, VkPipelineStageFlags src, VkAccessFlags src_access, VkPipelineStageFlags dst,
             VkAccessFlags dst_access) {
  VkMemoryBarrier mb{};
  mb.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  mb.srcAccessMask = src_access;
  mb.dstAccessMask = dst_access;
  vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &mb, 0, nullptr, 0, nullptr);
}

// One intersect call: the rays in chunks a binding can hold, one dispatch each, all in one
// submission bracketed by timestamps.
template <bool Any, typename T>
double intersect(GpuContext& ctx, const GpuBlock& block_base, const GpuRays& rays_base, std::span<T> out,
                 GpuDispatchStats* stats) {
  const auto& block = dynamic_cast<const BlockImpl&>(block_base);
  const auto& rays = dynamic_cast<const RaysImpl&>(rays_base);
  const std::shared_ptr<Core> core_ptr = detail::core_of(ctx);
  Core& core = *core_ptr;
  if (block.core != core_ptr || rays.core != core_ptr)
    throw std::invalid_argument("GPU: block and rays must come from the context that dispatches them");
  if (out.size() != rays.n)
    throw std::invalid_argument("GPU: output holds " + std::to_string(out.size()) + " results for " +
                                std::to_string(rays.n) + " rays");
  core.begin_op(Any ? "intersect_any dispatch" : "intersect_closest dispatch");
  GpuDispatchStats st;
  const std::uint64_t n = rays.n;
  if (n == 0) {
    if (stats) *stats = st;
    return 0;
  }
  const std::uint64_t stride = Any ? 4 : sizeof(GpuHit);
  const std::uint64_t range = core.props.limits.maxStorageBufferRange;
  std::uint64_t chunk = std::min<std::uint64_t>({std::uint64_t(core.props.limits.maxComputeWorkGroupCount[0]) * kLocalSize,
                                                  range / sizeof(GpuRay), range / stride});
  chunk -= chunk % 256;  // offsets stay multiples of minStorageBufferOffsetAlignment (<= 256)
  const auto chunks = static_cast<std::uint32_t>((n + chunk - 1) / chunk);
  const std::uint64_t out_bytes = n * stride;

  detail::SlotLease slot(core);
  ensure_scratch(core, slot->out_device, out_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                 Mem::Device);
  Buffer* result = &slot->out_device;
  if (!slot->out_device.mapped) {
    ensure_scratch(core, slot->out_host, out_bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Mem::Readback);
    result = &slot->out_host;
  }
  ensure_descriptors(core, *slot, chunks);
  std::vector<VkDescriptorSet> sets(chunks);
  std::vector<VkDescriptorSetLayout> layouts(chunks, core.pipelines.set_layout);
  VkDescriptorSetAllocateInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  ai.descriptorPool = slot->descriptors;
  ai.descriptorSetCount = chunks;
  ai.pSetLayouts = layouts.data();
  check(vkAllocateDescriptorSets(core.device, &ai, sets.data()), "vkAllocateDescriptorSets", &core);
  const bool empty = block.node_count == 0;  // an empty block binds a dummy buffer
  const VkDescriptorBufferInfo nodes{empty ? core.dummy.buffer : block.data.buffer, 0,
                                     empty ? VK_WHOLE_SIZE : block.node_bytes};
  const VkDescriptorBufferInfo tris{empty ? core.dummy.buffer : block.data.buffer, empty ? 0 : block.tri_offset,
                                    empty ? VK_WHOLE_SIZE : block.tri_bytes};
  for (std::uint32_t c = 0; c < chunks; ++c) {
    const std::uint64_t first = std::uint64_t(c) * chunk, count = std::min(chunk, n - first);
    const VkDescriptorBufferInfo bi[4] = {nodes,
                                          tris,
                                          {rays.rays.buffer, first * sizeof(GpuRay), count * sizeof(GpuRay)},
                                          {slot->out_device.buffer, first * stride, count * stride}};
    VkWriteDescriptorSet w[4]{};
    for (std::uint32_t k = 0; k < 4; ++k) {
      w[k].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
      w[k].dstSet = sets[c];
      w[k].dstBinding = k;
      w[k].descriptorCount = 1;
      w[k].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      w[k].pBufferInfo = &bi[k];
    }
    vkUpdateDescriptorSets(core.device, 4, w, 0, nullptr);
  }

  const auto t_record = Clock::now();
  detail::begin_commands(core, *slot);
  VkCommandBuffer cmd = slot->cmd;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, Any ? core.pipelines.any : core.pipelines.closest);
  if (core.timestamps) {
    vkCmdResetQueryPool(cmd, slot->queries, 0, 3);
    vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, slot->queries, 0);
  }
  for (std::uint32_t c = 0; c < chunks; ++c) {
    const std::uint64_t first = std::uint64_t(c) * chunk, count = std::min(chunk, n - first);
    const std::uint32_t push[3] = {static_cast<std::uint32_t>(count), block.node_count, block.root};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, core.pipelines.layout, 0, 1, &sets[c], 0, nullptr);
    vkCmdPushConstants(cmd, core.pipelines.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), push);
    vkCmdDispatch(cmd, static_cast<std::uint32_t>((count + kLocalSize - 1) / kLocalSize), 1, 1);
  }
  if (core.timestamps) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, slot->queries, 1);
  if (result == &slot->out_device) {
    barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
            VK_ACCESS_HOST_READ_BIT);
  } else {
    barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
            VK_ACCESS_TRANSFER_READ_BIT);
    const VkBufferCopy region{0, 0, out_bytes};
    vkCmdCopyBuffer(cmd, slot->out_device.buffer, slot->out_host.buffer, 1, &region);
    barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
            VK_ACCESS_HOST_READ_BIT);
  }
  if (core.timestamps) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, slot->queries, 2);
  core.submit_and_wait(*slot);
  st.submit_seconds = since(t_record);
  st.dispatches = chunks;
  st.kernel_seconds = st.submit_seconds;
  if (core.timestamps) {
    std::uint64_t ts[3] = {0, 0, 0};
    const VkResult r = vkGetQueryPoolResults(core.device, slot->queries, 0, 3, sizeof(ts), ts, sizeof(ts[0]),
                                             VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    check(r, "vkGetQueryPoolResults", &core);
    auto seconds = [&](std::uint64_t a, std::uint64_t b) {
      const std::uint64_t ticks = ((b & core.timestamp_mask) - (a & core.timestamp_mask)) & core.timestamp_mask;
      return double(ticks) * core.timestamp_ns * 1e-9;
    };
    st.kernel_seconds = seconds(ts[0], ts[1]);
    if (result != &slot->out_device) st.copy_seconds = seconds(ts[1], ts[2]);
    st.gpu_timestamps = true;
  }

  const auto t_down = Clock::now();
  if (!result->coherent) {
    VkMappedMemoryRange mr{};
    mr.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
    mr.memory = result->memory;
    mr.size = VK_WHOLE_SIZE;
    check(vkInvalidateMappedMemoryRanges(core.device, 1, &mr), "vkInvalidateMappedMemoryRanges", &core);
  }
  if constexpr (Any) {
    const auto* src = static_cast<const std::uint32_t*>(result->mapped);
    for (std::uint64_t i = 0; i < n; ++i) out[i] = static_cast<std::uint8_t>(src[i]);  // kAny* codes
  } else {
    std::memcpy(out.data(), result->mapped, out_bytes);
  }
  st.download_seconds = since(t_down);
  st.download_bytes = out_bytes;
  if (stats) *stats = st;
  return st.kernel_seconds;
}

}  // namespace

std::unique_ptr<GpuBlock> upload_block(GpuContext& ctx, std::span<const unsigned char> records,
                                       std::uint64_t triangle_count) {
  return upload_block(ctx, records, triangle_count, GpuBuildOptions{});
}

std::unique_ptr<GpuBlock> upload_block(GpuContext& ctx, std::span<const unsigned char> records,
                                       std::uint64_t triangle_count, const GpuBuildOptions& options) {
  const std::shared_ptr<Core> core = detail::core_of(ctx);
  if (records.size() < triangle_count * 40)
    throw std::invalid_argument("GPU: block payload of " + std::to_string(records.size()) + " bytes is shorter than " +
                                std::to_string(triangle_count) + " records");
  core->begin_op("block upload");
  // Fail before the build when the triangles alone cannot be bound.
  check_binding(*core, triangle_count * sizeof(bvh::Tri), "triangles", triangle_count);

  auto block = std::make_unique<BlockImpl>();
  block->core = core;
  block->n = triangle_count;
  detail::BuildLease cache(*core);
  bvh::FlatBvh& b = cache->flat;
  bvh::build(records, triangle_count, options, b, cache->scratch);
  block->build_seconds = b.seconds;
  block->bvh_nodes = b.nodes.size();
  block->leaf_triangles = b.tris.size();
  block->bvh_depth = b.depth;
  if (!b.nodes.empty()) {
    const std::uint64_t node_bytes = b.nodes.size() * sizeof(bvh::Node), tri_bytes = b.tris.size() * sizeof(bvh::Tri);
    check_binding(*core, node_bytes, "BVH nodes", triangle_count);
    check_binding(*core, tri_bytes, "triangles", triangle_count);
    const auto t0 = Clock::now();
    // One allocation per block (maxMemoryAllocationCount is 4096 on many GPUs).
    const std::uint64_t align = std::max<std::uint64_t>(core->props.limits.minStorageBufferOffsetAlignment, 16);
    block->node_bytes = node_bytes;
    block->tri_offset = (node_bytes + align - 1) / align * align;
    block->tri_bytes = tri_bytes;
    block->data = detail::make_buffer(*core, block->tri_offset + tri_bytes, kData, Mem::Device, true);
    detail::write_buffer(*core, block->data, b.nodes.data(), node_bytes, 0);
    detail::write_buffer(*core, block->data, b.tris.data(), tri_bytes, block->tri_offset);
    block->node_count = static_cast<std::uint32_t>(b.nodes.size());
    block->root = b.root;
    block->upload_seconds = since(t0);
  }
  return block;
}

std::unique_ptr<GpuRays> upload_rays(GpuContext& ctx, std::span<const GpuRay> rays) {
  const std::shared_ptr<Core> core = detail::core_of(ctx);
  core->begin_op("ray upload");
  auto q = std::make_unique<RaysImpl>();
  q->core = core;
  q->n = rays.size();
  if (!rays.empty()) q->rays = upload_array(*core, rays.data(), rays.size_bytes());
  return q;
}

double intersect_closest(GpuContext& ctx, const GpuBlock& block, const GpuRays& rays, std::span<GpuHit> out) {
  return intersect<false>(ctx, block, rays, out, nullptr);
}
double intersect_closest(GpuContext& ctx, const GpuBlock& block, const GpuRays& rays, std::span<GpuHit> out,
                         GpuDispatchStats* stats) {
  return intersect<false>(ctx, block, rays, out, stats);
}
double intersect_any(GpuContext& ctx, const GpuBlock& block, const GpuRays& rays, std::span<std::uint8_t> out) {
  return intersect<true>(ctx, block, rays, out, nullptr);
}
double intersect_any(GpuContext& ctx, const GpuBlock& block, const GpuRays& rays, std::span<std::uint8_t> out,
                     GpuDispatchStats* stats) {
  return intersect<true>(ctx, block, rays, out, stats);
}

}  // namespace rayline::gpu

// Buffers and host <-> device copies. Memory types are chosen once per device
// (vulkan_device.cpp): device-local for the kernels' data, host-visible staging for
// transfers, and direct mapping where device-local memory is host-visible on a device that
// shares host memory (lavapipe: one 2 GiB heap with every property bit).
#include <algorithm>
#include <cstring>
#include <string>

#include "render/vulkan/vulkan_internal.hpp"

namespace rayline::gpu::detail {

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    reset();
    core = o.core, buffer = o.buffer, memory = o.memory, size = o.size, type = o.type;
    host_visible = o.host_visible, coherent = o.coherent, accounted = o.accounted, mapped = o.mapped;
    o.buffer = VK_NULL_HANDLE, o.memory = VK_NULL_HANDLE, o.mapped = nullptr, o.size = 0, o.accounted = false;
  }
  return *this;
}

void Buffer::reset() {
  if (!core) return;
  if (mapped) vkUnmapMemory(core->device, memory);
  if (buffer) vkDestroyBuffer(core->device, buffer, nullptr);
  if (memory) vkFreeMemory(core->device, memory, nullptr);
  if (accounted) core->accounted_bytes -= size;
  buffer = VK_NULL_HANDLE, memory = VK_NULL_HANDLE, mapped = nullptr, size = 0, accounted = false;
}

namespace {

std::string mib(std::uint64_t b) { return std::to_string((b + (1u << 20) - 1) >> 20) + " MiB"; }

VkMemoryPropertyFlags flags_of(const Core& c, std::uint32_t type) { return c.memory.memoryTypes[type].propertyFlags; }

// `wanted` if the buffer may live there, else another type with the same properties.
std::uint32_t usable_type(const Core& c, std::uint32_t wanted, std::uint32_t allowed_bits) {
  if (allowed_bits & (1u << wanted)) return wanted;
  const VkMemoryPropertyFlags need = flags_of(c, wanted);
  for (std::uint32_t t = 0; t < c.memory.memoryTypeCount; ++t)
    if ((allowed_bits & (1u << t)) && (flags_of(c, t) & need) == need) return t;
  return UINT32_MAX;
}

}  // namespace

Buffer make_buffer(Core& core, VkDeviceSize bytes, VkBufferUsageFlags usage, Mem mem, bool accounted) {
  Buffer b;
  b.core = &core;
  VkBufferCreateInfo bi{};
  bi.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  bi.size = bytes;
  bi.usage = usage;
  bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(core.device, &bi, nullptr, &b.buffer), "vkCreateBuffer", &core);
  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(core.device, b.buffer, &req);
  const std::uint32_t wanted =
      mem == Mem::Device ? core.type_device : (mem == Mem::Upload ? core.type_upload : core.type_readback);
  b.type = usable_type(core, wanted, req.memoryTypeBits);
  if (b.type == UINT32_MAX)
    throw GpuError(GpuErrorKind::Failed, "GPU: no memory type of '" + core.info.name + "' can hold this buffer");
  const VkMemoryHeap& heap = core.memory.memoryHeaps[core.memory.memoryTypes[b.type].heapIndex];
  if (req.size > heap.size || (core.max_allocation && req.size > core.max_allocation))
    throw GpuError(GpuErrorKind::OutOfMemory, "GPU: " + mib(req.size) + " do not fit in one allocation on '" +
                                                  core.info.name + "' (heap " + mib(heap.size) +
                                                  ", maxMemoryAllocationSize " + mib(core.max_allocation) + ")");
  VkMemoryAllocateInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = b.type;
  const VkResult r = vkAllocateMemory(core.device, &ai, nullptr, &b.memory);
  if (r != VK_SUCCESS) {
    b.memory = VK_NULL_HANDLE;
    // TOO_MANY_OBJECTS: maxMemoryAllocationCount (4096 on many GPUs) reached: as good as full.
    if (kind_of(r) == GpuErrorKind::OutOfMemory || r == VK_ERROR_TOO_MANY_OBJECTS)
      throw GpuError(GpuErrorKind::OutOfMemory, "Vulkan: vkAllocateMemory of " + mib(req.size) + " on '" +
                                                    core.info.name + "' failed: " + vk_result_name(r));
    throw_vk("vkAllocateMemory", r, &core);
  }
  b.size = bytes;
  if (accounted) {
    b.accounted = true;
    core.accounted_bytes += bytes;
  }
  check(vkBindBufferMemory(core.device, b.buffer, b.memory, 0), "vkBindBufferMemory", &core);
  const VkMemoryPropertyFlags f = flags_of(core, b.type);
  b.host_visible = f & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
  b.coherent = f & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  // Device data is mapped only where the host writes it directly (core.direct); else it
  // is reached through staging even when the type happens to be host-visible.
  if (b.host_visible && (mem != Mem::Device || core.direct))
    check(vkMapMemory(core.device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory", &core);
  return b;
}

void write_buffer(Core& core, Buffer& dst, const void* src, VkDeviceSize bytes, VkDeviceSize dst_offset) {
  if (bytes == 0) return;
  if (dst.mapped) {
    std::memcpy(static_cast<unsigned char*>(dst.mapped) + dst_offset, src, bytes);
    if (!dst.coherent) {
      VkMappedMemoryRange range{};
      range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
      range.memory = dst.memory;
      range.size = VK_WHOLE_SIZE;
      check(vkFlushMappedMemoryRanges(core.device, 1, &range), "vkFlushMappedMemoryRanges", &core);
    }
    return;  // vkQueueSubmit makes host writes visible to later submissions
  }
  // Through the reused staging buffer, in chunks of at most kStagingBytes.
  std::lock_guard lk(core.staging_mutex);
  const VkDeviceSize want = std::min(bytes, kStagingBytes);
  if (!core.staging || core.staging.size < want) {
    core.scratch_bytes -= core.staging.size;
    core.staging.reset();
    core.staging = make_buffer(core, std::max<VkDeviceSize>(want, VkDeviceSize(4) << 20),
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Mem::Upload, false);
    core.scratch_bytes += core.staging.size;
  }
  Buffer& staging = core.staging;
  SlotLease slot(core);
  for (VkDeviceSize off = 0; off < bytes; off += staging.size) {
    const VkDeviceSize len = std::min(staging.size, bytes - off);
    std::memcpy(staging.mapped, static_cast<const unsigned char*>(src) + off, len);
    if (!staging.coherent) {
      VkMappedMemoryRange range{};
      range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
      range.memory = staging.memory;
      range.size = VK_WHOLE_SIZE;
      check(vkFlushMappedMemoryRanges(core.device, 1, &range), "vkFlushMappedMemoryRanges", &core);
    }
    begin_commands(core, *slot);
    VkBufferCopy region{0, dst_offset + off, len};
    vkCmdCopyBuffer(slot->cmd, staging.buffer, dst.buffer, 1, &region);
    // Later submissions on this queue read it in compute shaders.
    VkMemoryBarrier mb{};
    mb.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    mb.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
    vkCmdPipelineBarrier(slot->cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &mb,
                         0, nullptr, 0, nullptr);
    core.submit_and_wait(*slot);
  }
}

}  // namespace rayline::gpu::detail

// Private to render/vulkan: the Vulkan objects behind GpuContext (pimpl) and the helpers the
// kernels use (buffers, memory types, submissions). Never included by public headers.
#pragma once
#include <vulkan/vulkan.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "render/vulkan/gpu_bvh.hpp"
#include "render/vulkan/vulkan_device.hpp"

namespace rayline::gpu::detail {

struct Core;

// "VK_ERROR_OUT_OF_DEVICE_MEMORY" etc.
std::string vk_result_name(VkResult r);
// OUT_OF_{DEVICE,HOST}_MEMORY -> OutOfMemory, DEVICE_LOST -> DeviceLost,
// INCOMPATIBLE_DRIVER / INITIALIZATION_FAILED (no ICD) -> NoVulkan, else Failed.
GpuErrorKind kind_of(VkResult r);
// Throws GpuError naming the call and the result; DeviceLost also marks `core` lost.
[[noreturn]] void throw_vk(const char* call, VkResult r, Core* core = nullptr);
inline void check(VkResult r, const char* call, Core* core = nullptr) {
  if (r != VK_SUCCESS) throw_vk(call, r, core);
}

// Which memory a buffer lives in.
enum class Mem : std::uint8_t {
  Device,    // device-local (the data the kernels read and write)
  Upload,    // host-visible, coherent (staging for host -> device)
  Readback,  // host-visible, cached where possible (device -> host)
};

// A VkBuffer with its own VkDeviceMemory. Move-only; frees both on destruction. `core`
// must outlive it (owners hold a shared_ptr<Core> declared before their buffers).
struct Buffer {
  Core* core = nullptr;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  std::uint32_t type = 0;    // memory type index
  bool host_visible = false;
  bool coherent = false;
  bool accounted = false;    // counted in GpuContext::allocated_bytes (blocks, ray queues)
  void* mapped = nullptr;    // persistent mapping of host-visible memory

  Buffer() = default;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  Buffer(Buffer&& o) noexcept { *this = std::move(o); }
  Buffer& operator=(Buffer&& o) noexcept;
  ~Buffer() { reset(); }
  void reset();
  explicit operator bool() const { return buffer != VK_NULL_HANDLE; }
};

// Allocates `bytes` (> 0) in `mem`. Throws GpuError(OutOfMemory) when the memory cannot
// hold it (checked against the heap size and maxMemoryAllocationSize first, then
// vkAllocateMemory's own answer). Host-visible memory is mapped.
Buffer make_buffer(Core& core, VkDeviceSize bytes, VkBufferUsageFlags usage, Mem mem, bool accounted);

// One command buffer with everything a submission needs; a thread leases one for one
// operation (upload or dispatch), so two threads never share a pool (Vulkan's external
// synchronisation rule) and only vkQueueSubmit itself is serialised.
struct Slot {
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkDescriptorPool descriptors = VK_NULL_HANDLE;
  std::uint32_t descriptor_sets = 0;  // capacity of `descriptors`
  VkQueryPool queries = VK_NULL_HANDLE;
  Buffer out_device;  // kernel output scratch (device-local), grown on demand
  Buffer out_host;    // its host copy (discrete GPUs only)
};

// A BVH build's arrays, reused by the next build (bvh::BuildScratch).
struct BuildCache {
  bvh::FlatBvh flat;
  bvh::BuildScratch scratch;
  std::uint64_t bytes() const { return bvh::capacity_bytes(flat) + scratch.bytes(); }
};

// Host-visible staging for uploads to device-local memory that the host cannot map
// (discrete GPUs), reused between uploads; larger uploads go through it in chunks.
inline constexpr VkDeviceSize kStagingBytes = VkDeviceSize(64) << 20;

struct Pipelines {
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline closest = VK_NULL_HANDLE;
  VkPipeline any = VK_NULL_HANDLE;
};

// The device everything else keeps alive (blocks and ray queues hold a shared_ptr).
struct Core {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t family = 0;
  VkPhysicalDeviceProperties props{};
  VkPhysicalDeviceMemoryProperties memory{};
  VkDeviceSize max_allocation = 0;  // VkPhysicalDeviceMaintenance3Properties (Vulkan 1.1)
  GpuDeviceInfo info;

  bool timestamps = false;      // timestampValidBits > 0 and timestampComputeAndGraphics
  std::uint64_t timestamp_mask = 0;
  double timestamp_ns = 1.0;    // timestampPeriod
  // Device-local memory the host can map directly (lavapipe, integrated GPUs): no
  // staging copies. Discrete GPUs stage through host memory (reading device memory
  // through a PCIe BAR is very slow).
  bool direct = false;
  std::uint32_t type_device = UINT32_MAX, type_upload = UINT32_MAX, type_readback = UINT32_MAX;

  Pipelines pipelines;
  Buffer dummy;  // bound in place of an empty block's arrays (a binding cannot be empty)

  std::mutex queue_mutex;  // vkQueueSubmit / vkQueueWaitIdle are externally synchronised
  std::atomic<std::uint64_t> accounted_bytes{0};
  std::atomic<std::uint64_t> scratch_bytes{0};
  std::atomic<bool> lost{false};

  std::mutex fault_mutex;
  int fault_countdown = 0;  // 0: disarmed
  GpuErrorKind fault_kind = GpuErrorKind::Failed;

  std::mutex slot_mutex;
  std::vector<std::unique_ptr<Slot>> free_slots;

  std::mutex build_mutex;
  std::vector<std::unique_ptr<BuildCache>> free_builds;
  std::atomic<std::uint64_t> build_bytes{0};  // held by idle build caches

  std::mutex staging_mutex;  // one upload through `staging` at a time
  Buffer staging;

  Core() = default;
  Core(const Core&) = delete;
  Core& operator=(const Core&) = delete;
  ~Core();

  // Start of a GPU operation (block upload, ray upload, dispatch): throws DeviceLost once
  // the device is lost, and fires an injected fault when its countdown reaches zero.
  void begin_op(const char* what);
  std::unique_ptr<Slot> acquire_slot();
  void release_slot(std::unique_ptr<Slot> s);
  std::unique_ptr<BuildCache> acquire_build();
  void release_build(std::unique_ptr<BuildCache> b);
  void release_scratch();  // frees idle slots' output buffers, idle build caches, staging
  // Ends the slot's command buffer, submits it (serialised), waits for its fence.
  void submit_and_wait(Slot& s);
};

// RAII lease of a slot: returned to the pool on scope exit (dropped when the device is lost).
class SlotLease {
 public:
  explicit SlotLease(Core& c) : core_(c), slot_(c.acquire_slot()) {}
  ~SlotLease() {
    if (slot_) core_.release_slot(std::move(slot_));
  }
  SlotLease(const SlotLease&) = delete;
  SlotLease& operator=(const SlotLease&) = delete;
  Slot& operator*() const { return *slot_; }
  Slot* operator->() const { return slot_.get(); }

 private:
  Core& core_;
  std::unique_ptr<Slot> slot_;
};

// RAII lease of a build cache.
class BuildLease {
 public:
  explicit BuildLease(Core& c) : core_(c), cache_(c.acquire_build()) {}
  ~BuildLease() { core_.release_build(std::move(cache_)); }
  BuildLease(const BuildLease&) = delete;
  BuildLease& operator=(const BuildLease&) = delete;
  BuildCache* operator->() const { return cache_.get(); }

 private:
  Core& core_;
  std::unique_ptr<BuildCache> cache_;
};

// Begins recording the slot's (reset) command buffer for one submission.
void begin_commands(Core& core, Slot& s);

// Copies `bytes` from the host into `dst` at `dst_offset`: a memcpy where `dst` is mapped,
// else through the staging buffer and vkCmdCopyBuffer.
void write_buffer(Core& core, Buffer& dst, const void* src, VkDeviceSize bytes, VkDeviceSize dst_offset = 0);

// Creates the compute pipelines (shaders compiled into the library).
void create_pipelines(Core& core);
void destroy_pipelines(Core& core);

// The context's shared core (GpuContext::Impl holds it).
std::shared_ptr<Core> core_of(GpuContext& ctx);

}  // namespace rayline::gpu::detail

namespace rayline::gpu {
struct GpuContext::Impl {
  std::shared_ptr<detail::Core> core;
};
}  // namespace rayline::gpu

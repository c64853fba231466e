// The GPU side of the RAM<->GPU channel (Fig. 2's GPU memory device): scene blocks
// and ray queues resident in the memory of one Vulkan device. As in BlockStore, a block
// enters only through a planned T-job (upload: its triangles rebuilt from the RAM copy, a
// GPU BVH built on the CPU) and leaves only through a planned eviction; a ray queue is
// uploaded by its T-job and consumed by its E-job.
//
// Failure never loses work: an upload that runs out of GPU memory leaves the block absent
// (its jobs then run on the CPU path), and a lost device marks the store lost, after which
// every GPU job of the plan runs on the CPU path and the renderer stops planning for the GPU.
// The E-jobs themselves run in render/accel/vulkan_aggregate.hpp, on what this store holds.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "render/integrator/path_kernels.hpp"
#include "render/store/block_store.hpp"
#include "render/vulkan/gpu_kernels.hpp"
#include "sched/core/types.hpp"

namespace rayline::engine {

struct GpuStoreStats {
  std::uint64_t block_uploads = 0, block_evictions = 0, upload_failures = 0;
  std::uint64_t ray_uploads = 0, unplanned_ray_uploads = 0;
  std::uint64_t block_bytes = 0, ray_bytes = 0;       // uploaded
  double build_seconds = 0, upload_seconds = 0;       // BVH builds, block copies
  std::uint64_t peak_device_bytes = 0;
  std::uint64_t gpu_jobs = 0, fallback_jobs = 0;      // E-jobs on the GPU / run on the CPU path instead
  std::uint64_t gpu_rays = 0, fallback_rays = 0;
  double kernel_seconds = 0;                          // sum of kernel times
  // Rays the kernels flagged doubtful (render/vulkan/README.md, "Doubtful rays"): handed back
  // as kRayCpuOnly rays (resolve_doubtful) or, with it off, answered by the kernel's guess.
  std::uint64_t doubtful_rays = 0;
};

class GpuStore {
 public:
  GpuStore(gpu::GpuContext& ctx, BlockStore& ram);

  // T-job RAM->GPU of a scene block. Never throws GpuError (see the file comment).
  void load(std::uint32_t cell);
  void evict(std::uint32_t cell);
  // T-job RAM->GPU of a ray queue (the rays as the kernels read them: query intervals).
  void load_rays(BlockId queue, std::span<const trace::RayRecord> rays, const trace::TraceSettings& ts);
  void drop_rays(BlockId queue);

  // What an E-job on the GPU reads (render/accel/vulkan_aggregate.hpp): the resident copy
  // of `cell` (nullptr when absent or the device is lost), and the queue's rays uploaded by
  // its T-job (taken: an E-job consumes its queues; nullptr when the T-job failed or was
  // not planned).
  std::shared_ptr<const gpu::GpuBlock> resident(std::uint32_t cell) const;
  std::unique_ptr<gpu::GpuRays> take_rays(BlockId queue);
  // Uploads a queue the plan did not upload (counted). Throws GpuError.
  std::unique_ptr<gpu::GpuRays> upload_unplanned(std::span<const trace::RayRecord> rays,
                                                 const trace::TraceSettings& ts);
  // A GpuError of an upload or a kernel: remembered; a lost device empties the store.
  void note_error(const gpu::GpuError& e);
  // One finished E-job: rays searched on the GPU (`on_gpu` of `rays`), on the CPU path
  // (`fallback`), flagged doubtful, and the kernels' time.
  void note_job(std::uint64_t rays, std::uint64_t on_gpu, std::uint64_t fallback, std::uint64_t doubtful,
                double kernel_seconds);

  bool lost() const;
  std::string failure() const;  // the first GPU error, "" if none
  GpuStoreStats stats() const;
  gpu::GpuContext& context() { return ctx_; }

 private:
  std::unique_ptr<gpu::GpuRays> pack_upload(std::span<const trace::RayRecord> rays, const trace::TraceSettings& ts);

  gpu::GpuContext& ctx_;
  BlockStore& ram_;
  mutable std::mutex mu_;
  std::map<std::uint32_t, std::shared_ptr<const gpu::GpuBlock>> blocks_;
  std::map<std::uint32_t, int> copies_;
  std::map<BlockId, std::unique_ptr<gpu::GpuRays>> rays_;
  bool lost_ = false;
  std::string failure_;
  GpuStoreStats stats_;
};

}  // namespace rayline::engine

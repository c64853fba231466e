// The GPU side of the RAM<->GPU channel (Fig. 2's GPU memory device): scene blocks
// and ray queues resident in the memory of one Vulkan device. As in BlockStore, a block
// enters only through a planned T-job (upload: its triangles rebuilt from the RAM copy, a
// GPU BVH built on the CPU) and leaves only through a planned eviction; a ray queue is
// uploaded by its T-job and consumed by its E-job.
//
// Failure never loses work: an upload that runs out of GPU memory leaves the block absent
// (its jobs then run on the CPU path), and a lost device marks the store lost, after which
// every GPU job of the plan runs on the CPU path and the renderer stops planning for the GPU.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "render/engine/block_store.hpp"
#include "render/gpu/gpu_kernels.hpp"
#include "render/trace/path_kernels.hpp"
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
  // Rays the kernels flagged doubtful (render/gpu/README.md, "Doubtful rays"): handed back
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

  // The E-jobs: RayIntersect / ShadowIntersect of a job's queues on the GPU, shading on the
  // host. `parts` are the job's queues (block, ray count) in the order of `rays`. Parts the
  // GPU cannot run (block absent, device lost, a GpuError) run on the CPU path with the RAM
  // copy of the block. Rays the kernel flags doubtful go to `out` unchanged but for
  // kRayCpuOnly (the workload queues them for a CPU device: render/gpu/README.md), so the
  // image equals the CPU-only one by construction. Thread-safe.
  void run_job(const trace::TraceSettings& ts, std::uint32_t cell, trace::RayKind kind,
               std::span<const trace::RayRecord> rays, std::span<const std::pair<BlockId, std::uint32_t>> parts,
               std::vector<trace::RayRecord>& out, trace::RayCounts& counts);

  // Test hook: false takes the kernel's guess for doubtful rays (the image may then differ
  // from the CPU-only one at edge cracks and near ties).
  void set_resolve_doubtful(bool on) { resolve_doubtful_ = on; }

  bool lost() const;
  std::string failure() const;  // the first GPU error, "" if none
  GpuStoreStats stats() const;
  gpu::GpuContext& context() { return ctx_; }

 private:
  void note_error(const gpu::GpuError& e);
  std::unique_ptr<gpu::GpuRays> pack_upload(std::span<const trace::RayRecord> rays, const trace::TraceSettings& ts);

  gpu::GpuContext& ctx_;
  BlockStore& ram_;
  mutable std::mutex mu_;
  std::map<std::uint32_t, std::shared_ptr<const gpu::GpuBlock>> blocks_;
  std::map<std::uint32_t, int> copies_;
  std::map<BlockId, std::unique_ptr<gpu::GpuRays>> rays_;
  bool lost_ = false;
  bool resolve_doubtful_ = true;
  std::string failure_;
  GpuStoreStats stats_;
};

}  // namespace rayline::engine

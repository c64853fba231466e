// The GPU aggregate (aggregate.hpp): the Vulkan kernels (render/vulkan/gpu_kernels.hpp) on
// the GPU copy of the job's block, against the job's queues as their T-jobs uploaded them
// (render/store/gpu_store.hpp); the integrator then runs on the host on the hits the
// kernels return.
//
// Failure never loses work: a queue whose block is absent from the GPU (an upload ran out
// of memory, the device is lost, a kernel failed) runs on the CPU path, Embree on the RAM
// copy. Rays a kernel flags doubtful (render/vulkan/README.md, "Doubtful rays") go to `out`
// unchanged but for kRayCpuOnly: the workload queues them for a CPU device, so the image
// equals the CPU-only one by construction.
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "render/accel/aggregate.hpp"
#include "render/accel/embree_aggregate.hpp"
#include "render/store/gpu_store.hpp"

namespace rayline::accel {

class VulkanAggregate final : public Aggregate {
 public:
  // `resolve_doubtful` false is a test hook: doubtful rays take the kernel's own guess (the
  // image may then differ from the CPU-only one at edge cracks and near ties).
  VulkanAggregate(engine::GpuStore& gpu, engine::BlockStore& ram, bool resolve_doubtful = true)
      : gpu_(gpu), cpu_(ram), resolve_doubtful_(resolve_doubtful) {}

  void intersect_closest(const trace::TraceSettings& ts, const QueueJob& job, std::vector<trace::RayRecord>& out,
                         trace::RayCounts& counts) override {
    run(ts, job, out, counts);
  }
  void intersect_shadow(const trace::TraceSettings& ts, const QueueJob& job, std::vector<trace::RayRecord>& out,
                        trace::RayCounts& counts) override {
    run(ts, job, out, counts);
  }

 private:
  // The kernels' answers for one queue: closest hits (RayIntersect) or occlusion bits
  // (ShadowIntersect), one per ray.
  struct Answers {
    std::vector<gpu::GpuHit> hits;
    std::vector<std::uint8_t> occluded;
  };
  void run(const trace::TraceSettings& ts, const QueueJob& job, std::vector<trace::RayRecord>& out,
           trace::RayCounts& counts);
  // The kernel over one queue (uploaded now when its T-job did not); false, the error
  // noted, when the GPU failed.
  bool search(const trace::TraceSettings& ts, trace::RayKind kind, const gpu::GpuBlock& block,
              std::span<const trace::RayRecord> part, std::unique_ptr<gpu::GpuRays>& up, Answers& answers,
              double& kernel_seconds);
  // The integrator on the host for one queue's answers; returns the doubtful rays.
  std::uint64_t resolve(const trace::TraceSettings& ts, trace::RayKind kind, std::span<const trace::RayRecord> part,
                        const Answers& answers, std::vector<trace::RayRecord>& out, trace::RayCounts& counts) const;
  // One ray of it: true when the kernel flagged it doubtful.
  bool resolve_ray(const trace::TraceSettings& ts, trace::RayKind kind, const trace::RayRecord& r,
                   const Answers& answers, std::size_t i, std::vector<trace::RayRecord>& out,
                   trace::RayCounts& counts) const;

  engine::GpuStore& gpu_;
  EmbreeAggregate cpu_;  // the CPU path of queues the GPU cannot take
  bool resolve_doubtful_;
};

}  // namespace rayline::accel

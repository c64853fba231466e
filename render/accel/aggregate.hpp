// The intersection seam of ray batching (Fig. 3, Sec. 3.1): an E-job's ray queues searched
// against one resident block. pbrt-v4's wavefront integrator is the model: an aggregate
// with IntersectClosest / IntersectShadow over whole work queues, one CPU and one GPU
// implementation, and what happens after a hit written once — every aggregate hands each
// ray to the integrator (after_closest_hit / after_occlusion_test,
// render/integrator/path_kernels.hpp), so shading never depends on who found the hit.
//   EmbreeAggregate (embree_aggregate.hpp): Embree on the block's RAM copy;
//   VulkanAggregate (vulkan_aggregate.hpp): the Vulkan kernels on the block's GPU copy.
// The renderer picks one per compute device of the DCG (render/engine/aggregate_factory.hpp).
// One virtual call per E-job, none per ray.
#pragma once
#include <cstdint>
#include <functional>
#include <span>
#include <utility>
#include <vector>

#include "render/integrator/path_kernels.hpp"
#include "sched/core/types.hpp"

namespace rayline::accel {

// One E-job's rays: the ray queues merged into it (Sec. 5.1), all in cell `cell`.
struct QueueJob {
  std::uint32_t cell = 0;
  trace::RayKind kind = trace::RayKind::Path;
  std::span<const trace::RayRecord> rays;
  // The queues (ray queue block, ray count) in the order of `rays`; a queue moves to a GPU
  // as its own T-job, so the GPU finds it by its block.
  std::span<const std::pair<BlockId, std::uint32_t>> parts;
};

class Aggregate {
 public:
  virtual ~Aggregate() = default;
  // RayIntersect(SceneData_b, RayQueue_b): the closest hit of every ray in its cell; the
  // rays the integrator makes go to `out`, what happened to them to `counts`. Thread-safe:
  // every compute device of one kind may share one aggregate.
  virtual void intersect_closest(const trace::TraceSettings& ts, const QueueJob& job,
                                 std::vector<trace::RayRecord>& out, trace::RayCounts& counts) = 0;
  // ShadowIntersect(SceneData_b, ShadowRayQueue_b): whether anything in the cell blocks
  // each ray.
  virtual void intersect_shadow(const trace::TraceSettings& ts, const QueueJob& job,
                                std::vector<trace::RayRecord>& out, trace::RayCounts& counts) = 0;

  // Whether rays can be handed to this aggregate straight from a job's output, without a
  // queue of their own (true for the CPU: the block's RAM copy is where the rays are; the GPU
  // finds rays only in ray queues moved to it by T-jobs).
  virtual bool traces_in_place() const { return false; }

  // One pass of a job: its input rays, then (continuation) the rays they made in the same
  // cell, as a ray log sees them: rays of one kind in, every ray they made out.
  using PassObserver = std::function<void(trace::RayKind kind, std::span<const trace::RayRecord> in,
                                          std::span<const trace::RayRecord> out)>;

  // The E-job of `job.kind` rays. With `ts.continue_in_cell` on an aggregate that traces in
  // place, the rays the job makes in its own cell (shadow rays and continuations that start
  // there, Fig. 3's loop) are traced in the same job, pass after pass, instead of waiting in
  // a ray queue for a job of their own: the block is resident and the rays are in the cache.
  // Only rays for other cells reach `out`. Every ray is still traced once, in the same cell,
  // with the same query interval, so counts and the image are those of the queued route.
  void intersect(const trace::TraceSettings& ts, const QueueJob& job, std::vector<trace::RayRecord>& out,
                 trace::RayCounts& counts, const PassObserver& observe = {});

 private:
  void pass(const trace::TraceSettings& ts, const QueueJob& job, std::vector<trace::RayRecord>& out,
            trace::RayCounts& counts) {
    if (job.kind == trace::RayKind::Path) intersect_closest(ts, job, out, counts);
    else intersect_shadow(ts, job, out, counts);
  }
};

}  // namespace rayline::accel

// The real path tracer as a Workload: the shared ray-batching policy
// (workload/ray_batch_workload.hpp) over real ray records. Camera rays come from the
// pinhole camera; the E-jobs' kernels (ActivityTasks) fill each job's output rays and
// counts. With a ray-log recorder, every ray's outcome is also kept for the simulated
// twin (ray_log_recorder.hpp, docs/validation.md).
#pragma once
#include <cstdint>
#include <span>
#include <vector>

#include "render/integrator/camera.hpp"
#include "render/integrator/path_kernels.hpp"
#include "workload/camera_order.hpp"
#include "workload/ray_batch_workload.hpp"

namespace rayline::engine {

class ProfileRecorder;
class RayLogRecorder;

struct RenderRayTraits {
  static int slot(const trace::RayRecord& r) {
    return static_cast<int>(r.kind) + ((r.flags & trace::kRayCpuOnly) ? 2 : 0);
  }
};

struct RenderWorkloadOptions : RayBatchOptions {
  // per-cell statistics / replay log of every ray (profile_recorder.hpp); the
  // renderer then runs CPU kernels ray by ray and uses no GPU.
  ProfileRecorder* recorder = nullptr;
  // every ray's outcome for `simulate --like` (ray_log_recorder.hpp); jobs keep their
  // input rays until the loop has seen them.
  RayLogRecorder* ray_log = nullptr;
};

using RayJob = RayBatchJob<trace::RayRecord, trace::RayCounts>;

class RenderWorkload final : public RayBatchWorkload<trace::RayRecord, trace::RayCounts, RenderRayTraits> {
 public:
  RenderWorkload(const trace::TraceSettings& ts, const trace::PinholeCamera& camera, const DeviceGraph& g,
                 MemId ram, std::vector<BlockId> scene_blocks, RenderWorkloadOptions opt);
  // The ray log being recorded (nullptr: none): a job's kernel keeps its input rays' ids.
  const RayLogRecorder* ray_log() const { return ray_log_; }
  // A camera job's rays (RayBatchOptions::camera_jobs), made on the job's thread: camera
  // rays [first, first + n) of the camera order (workload/camera_order.hpp), each exactly as
  // the loop would make it; those that enter a cell go to `placed`, those that miss every
  // cell end at once (film and counts). `ts` is this workload's settings, or a copy whose
  // film is the job's window. Thread-safe.
  void camera_job_rays(const trace::TraceSettings& ts, std::uint64_t first, std::uint64_t n,
                       std::vector<trace::RayRecord>& placed, trace::RayCounts& counts) const;
  const CameraOrder& camera_order() const { return order_; }

 private:
  trace::RayCounts make_camera_rays(std::uint64_t first, std::uint64_t n) override;
  void job_done(RayJob& job) override;

  trace::TraceSettings ts_;
  const trace::PinholeCamera& camera_;
  CameraOrder order_;
  ProfileRecorder* recorder_;
  RayLogRecorder* ray_log_;
};

}  // namespace rayline::engine

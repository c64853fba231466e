// The real path tracer as a Workload (docs/architecture.md control loop; Fig. 3, Sec. 3.1, 5.1):
// camera rays are generated in waves (at most `path_cap` paths alive, which bounds ray
// memory), every ray waits in the queue of the cell it is in, and a queue becomes a
// RayIntersect / ShadowIntersect E-job on (SceneData_b, RayQueue_b). A job's output rays
// are staged per cell; staged rays join the still-queued job of their cell (queues merge
// on arrival, Sec. 5.1) or become a new job once there are `min_batch` of them, or
// whenever fewer jobs are queued than there are compute devices.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <deque>
#include <unordered_map>
#include <utility>
#include <vector>

#include "render/integrator/camera.hpp"
#include "render/integrator/path_kernels.hpp"
#include "sched/runtime/workload.hpp"

namespace rayline::engine {

class ProfileRecorder;

struct RenderWorkloadOptions {
  int spp = 4;
  std::uint32_t path_cap = 1u << 17;   // paths alive at once (RenderOptions: 0 = auto, renderer.cpp)
  std::uint32_t min_batch = 4096;      // rays per job before a queue is worth a job
  std::uint32_t max_batch = 1u << 16;  // rays per job at most (load balance)
  // per-cell statistics / replay log of every ray (profile_recorder.hpp); the
  // renderer then runs CPU kernels ray by ray and uses no GPU.
  ProfileRecorder* recorder = nullptr;
};

// The rays of one E-job and what it produced (written by the worker that runs it, read by
// the loop after the Finished event).
struct RayJob {
  trace::RayKind kind = trace::RayKind::Path;
  std::uint32_t cell = 0;
  std::vector<trace::RayRecord> rays;
  std::uint64_t input = 0;  // rays handed to the job (the kernel may trace more: trace_while_resident)
  // The job's ray queues (RayQueue/ShadowRayQueue blocks merged into it, Sec. 5.1) and
  // their ray counts, in the order of `rays`: a queue moves RAM->GPU as its own T-job.
  std::vector<std::pair<BlockId, std::uint32_t>> parts;
  std::vector<trace::RayRecord> out;
  trace::RayCounts counts;
};

class RenderWorkload final : public Workload {
 public:
  // `scene_blocks[c]` is the SceneData block of cell c (already in the pool, on disk).
  RenderWorkload(const trace::TraceSettings& ts, const trace::PinholeCamera& camera, const DeviceGraph& g,
                 MemId ram, std::vector<BlockId> scene_blocks, RenderWorkloadOptions opt);

  void start(Time now, JobPool& pool, Schedule& schedule) override;
  void on_job_finished(JobId job, Time now, JobPool& pool, Schedule& schedule) override;
  void on_idle(Time now, JobPool& pool, Schedule& schedule) override;
  bool finished() const override;

  // Stop making work (a job failed): finished() turns true.
  void abort() { aborted_ = true; }
  RayJob& job(JobId j) { return *jobs_.at(static_cast<std::size_t>(j)); }
  // The job a ray queue block was merged into (kNone for other blocks).
  JobId consumer(BlockId queue) const {
    auto it = consumer_.find(queue);
    return it == consumer_.end() ? kNone : it->second;
  }
  const trace::RayCounts& counts() const { return counts_; }
  std::uint64_t camera_rays() const { return next_camera_; }
  std::uint64_t total_camera_rays() const { return total_camera_; }
  std::uint64_t merges() const { return merges_; }
  std::uint64_t jobs_created() const { return jobs_created_; }
  std::uint64_t paths_alive() const { return paths_alive_; }

 private:
  void generate();  // camera rays into staging
  void stage(std::vector<trace::RayRecord>& rays);
  void flush(Time now, JobPool& pool, Schedule& s, bool all);
  // Staged rays of one (cell, slot): a FIFO whose taken front is skipped by `head` and
  // dropped once it is half the vector (each ray is copied O(1) times, not once per job).
  struct Staged {
    std::vector<trace::RayRecord> v;
    std::size_t head = 0;
    std::size_t size() const { return v.size() - head; }
    bool empty() const { return v.size() == head; }
    // Room for n more, growing geometrically (a queue grows at most once per staging).
    void reserve_more(std::size_t n) {
      if (v.capacity() < v.size() + n) v.reserve(std::max(v.size() + n, 2 * v.capacity()));
    }
  };
  void make_job(int slot, std::uint32_t cell, Staged& rays, std::size_t n, Time now, JobPool& pool, Schedule& s);

  trace::TraceSettings ts_;
  const trace::PinholeCamera& camera_;
  const DeviceGraph& g_;
  MemId ram_;
  std::vector<MemId> near_;  // memories compute devices work from (RAM, GPU memories)
  std::vector<BlockId> scene_blocks_;
  RenderWorkloadOptions opt_;
  // Slots: 0 path, 1 shadow, 2 and 3 the same kinds flagged kRayCpuOnly (doubtful on a GPU,
  // render/vulkan/README.md): job types RayIntersectCpu / ShadowIntersectCpu, which only CPU
  // devices support (renderer.cpp adds them when there is a GPU; without them, 0 and 1).
  static constexpr int kSlots = 4;
  static int slot_of(const trace::RayRecord& r) {
    return static_cast<int>(r.kind) + ((r.flags & trace::kRayCpuOnly) ? 2 : 0);
  }
  // The ray's queue as one index: cell * kSlots + slot.
  static std::size_t queue_of(const trace::RayRecord& r) {
    return std::size_t(r.cell) * kSlots + std::size_t(slot_of(r));
  }
  Staged& queue(std::size_t q) { return staging_[q / kSlots][q % kSlots]; }
  JobTypeId type_[kSlots];
  std::vector<std::array<Staged, kSlots>> staging_;  // per cell, per slot
  std::vector<std::array<JobId, kSlots>> open_;                               // queued job per cell, slot
  std::vector<std::unique_ptr<RayJob>> jobs_;                            // by JobId
  std::unordered_map<BlockId, JobId> consumer_;                          // ray queue -> its job
  trace::RayCounts counts_;
  std::uint64_t next_camera_ = 0, total_camera_ = 0;
  std::uint64_t paths_alive_ = 0, staged_ = 0, in_jobs_ = 0;
  std::uint64_t merges_ = 0, jobs_created_ = 0;
  bool aborted_ = false;
};

}  // namespace rayline::engine

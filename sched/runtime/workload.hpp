// The Workload seam (docs/architecture.md): turns finished jobs into new jobs. A static job set adds
// everything at the start; the ray-batching and path-tracing workloads add jobs as rays
// spawn rays (Sec. 3.1).
#pragma once
#include <vector>

#include "sched/core/job_pool.hpp"
#include "sched/timeline/schedule.hpp"

namespace rayline {

class Workload {
 public:
  virtual ~Workload() = default;
  virtual void start(Time now, JobPool& pool, Schedule& schedule) = 0;
  // An E-job finished at `now`; add the jobs (and blocks) it gives rise to.
  virtual void on_job_finished(JobId job, Time now, JobPool& pool, Schedule& schedule) = 0;
  // Called when nothing is in flight and nothing is queued: may add more (e.g. next frame).
  virtual void on_idle(Time /*now*/, JobPool& /*pool*/, Schedule& /*schedule*/) {}
  virtual bool finished() const = 0;

  // Faults (docs/faults.md). `jobs` were planned and are queued again (their E-jobs were
  // aborted; their inputs are still there).
  virtual void on_requeued(Time /*now*/, const std::vector<JobId>& /*jobs*/, JobPool& /*pool*/, Schedule& /*schedule*/) {}
  // `jobs` (already discarded from the pool) read data whose last copy was on a lost
  // memory device (`blocks`), directly or through another lost job. A workload that can
  // make the work again does so; this default cannot and throws std::runtime_error
  // naming what was lost (the run ends with exit code 1).
  virtual void on_lost(Time now, const std::vector<JobId>& jobs, const std::vector<BlockId>& blocks, JobPool& pool,
                       Schedule& schedule);
};

// All jobs known up front (rayline plan, tests). Blocks and jobs are already in the pool.
class StaticWorkload final : public Workload {
 public:
  void start(Time, JobPool&, Schedule&) override {}
  void on_job_finished(JobId, Time, JobPool&, Schedule&) override {}
  bool finished() const override { return true; }
};

}  // namespace rayline

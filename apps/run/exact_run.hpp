// A static job set run in-process (`rayline plan`): the platform, the job set (a file, or
// the synthetic ray-batching set), a scheduler from the factory and the ExactExecutor
// under the runtime loop, so the plan executes exactly as predicted and is re-planned
// whenever a device's timeline runs dry (Sec. 4.2).
#pragma once
#include <cstdint>
#include <memory>
#include <string>

#include "sched/policy/scheduler_factory.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "workload/job_set.hpp"

namespace rayline::cli {

struct ExactRunOptions {
  std::string platform_file;
  std::string jobs_file;  // empty: synthetic_ray_batching(blocks, jobs, seed)
  int synthetic_blocks = 129, synthetic_jobs = 1000;
  std::uint64_t seed = 1;
  SchedulerChoice scheduler;
};

class ExactRun {
 public:
  explicit ExactRun(const ExactRunOptions& opt);
  RunStats run();
  const DeviceGraph& graph() const { return graph_; }
  const JobPool& pool() const { return set_.pool; }
  const Schedule& schedule() const { return schedule_; }

 private:
  DeviceGraph graph_;
  JobSet set_;
  Schedule schedule_;
  std::unique_ptr<Scheduler> scheduler_;
  ExactExecutor executor_;
};

}  // namespace rayline::cli

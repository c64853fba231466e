// E-jobs (Sec. 4.1): a job of some type on a compute device, taking input data blocks and
// producing output data blocks on the memory device of that compute device. Job-job
// dependencies are either through data (an input produced by another job) or explicit
// (`after`). T-jobs are not Jobs: they are created by the scheduler as Activities on
// channels (Sec. 4.4).
#pragma once
#include <string>
#include <vector>

#include "sched/core/types.hpp"

namespace rayline {

struct Job {
  std::string name;
  JobTypeId type = kNone;
  std::vector<BlockId> inputs;
  std::vector<BlockId> outputs;  // produced on the executing device's memory device
  std::vector<JobId> after;      // must finish before this job starts
  Time created = 0;              // when it entered the global job queue (aging, Sec. 4.3)
  std::uint64_t work = 0;        // work units (rays) for throughput metrics
  JobId predicted_from = kNone;  // Sec. 5.2: the job whose outcome this one was predicted from
  // The node the workload made this job for (kNone: any). Set only when the scheduler asked
  // for it (Scheduler::ray_origin); a policy that never asks ignores it.
  NodeId node_hint = kNone;
  // Bytes the job will write that its outputs do not declare (the rays a GenerateRays job
  // makes; 0: none or unknown). A policy may keep room for them (docs/rayline-policy.md).
  Bytes expected_output_bytes = 0;
};

enum class JobState : std::uint8_t { Queued, Planned, Done, Discarded };

}  // namespace rayline

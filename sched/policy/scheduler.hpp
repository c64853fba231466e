// The engine-agnostic Scheduler seam (docs/architecture.md, control loop): GMB today, the baselines
// (Budge 2009, LoadAnyOnce) later, all driven by the same runtime loop and executors.
#pragma once
#include <string>

#include "sched/core/job_pool.hpp"
#include "sched/timeline/schedule.hpp"

namespace rayline {

struct PlanStats {
  int execs = 0;          // E-jobs placed
  int transfers = 0;      // T-jobs placed
  int evictions = 0;
  double wall_seconds = 0;
  std::uint64_t path_searches = 0, path_cache_hits = 0;
  std::uint64_t path_cut_searches = 0;  // SDC searches stopped at the destination / losing labels (GMB)
};

class Scheduler {
 public:
  virtual ~Scheduler() = default;
  virtual std::string name() const = 0;
  // The decision parameters, printed with every result.
  virtual std::string describe() const { return name(); }
  // Extend `schedule` with jobs from the queue of `pool`, planning every compute device up
  // to now + horizon (Sec. 4.2). New activities are appended (ids >= the count before).
  virtual PlanStats plan(Time now, JobPool& pool, Schedule& schedule) = 0;
};

}  // namespace rayline

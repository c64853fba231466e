// The engine-agnostic Scheduler seam (docs/architecture.md, control loop): GMB (Sec. 4.2-4.4)
// and the baselines (Budge 2009, LoadAnyOnce), all driven by the same runtime loop and
// executors (sched/policy/scheduler_factory.hpp makes them by name).
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
  // The runtime loop plans when a compute device enters the idle state or new jobs
  // arrive while one is idle (Sec. 4.2). True: also at every other batch of events while
  // any device stays idle (a plan may still top up timelines as `now` moves on); false:
  // only at those two events. GMB in plan cells answers false (docs/scheduler.md).
  virtual bool plans_while_idle() const { return true; }
};

}  // namespace rayline

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
  // Where camera rays should be made (Rayline's policy, rule 8): true when the policy wants
  // each wave of camera rays made on the node that owns the block they enter. A workload
  // that can then asks ray_origin() for the node of each (wave, entry block), makes one
  // GenerateRays job per node with that node as its Job::node_hint, and the policy runs it
  // there. False (the paper's GMB and the baselines): one job per wave, placed as usual.
  virtual bool places_ray_origins() const { return false; }
  // The node that should make wave `wave`'s rays entering scene block `entry` (kNone: no
  // preference). `wave` numbers the waves of a run; the same arguments give the same node.
  virtual NodeId ray_origin(std::uint64_t /*wave*/, BlockId /*entry*/, const JobPool& /*pool*/, const Schedule& /*s*/) {
    return kNone;
  }
};

}  // namespace rayline

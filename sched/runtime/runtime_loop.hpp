// The control loop shared by both engines (docs/architecture.md):
//   Workload --new jobs--> JobPool --> Scheduler.plan(now, k) --> Schedule --> Executor
//      ^------------- finished jobs (measured times, outputs) <----------------'
// The scheduler is invoked when a compute device's timeline runs dry while jobs are
// queued (Sec. 4.2), and whenever new jobs arrive while some device is idle.
#pragma once
#include <functional>

#include "sched/runtime/executor.hpp"
#include "sched/policy/scheduler.hpp"
#include "sched/runtime/workload.hpp"

namespace rayline {

struct RunStats {
  Time makespan = 0;
  int plan_calls = 0;
  double scheduler_wall_seconds = 0;
  std::uint64_t execs = 0, transfers = 0, evictions = 0;
  bool stalled = false;  // queued jobs left that no device could ever run
};

class RuntimeLoop {
 public:
  RuntimeLoop(Scheduler& scheduler, Executor& executor, Workload& workload, JobPool& pool, Schedule& schedule)
      : scheduler_(scheduler), executor_(executor), workload_(workload), pool_(pool), schedule_(schedule) {}

  // Runs until the workload is finished and nothing is queued or in flight, or `until`.
  RunStats run(Time until = kNever);
  // Called after every batch of events (progress reporting, metrics sampling).
  std::function<void(Time now, const RunStats&)> on_progress;

 private:
  void plan_and_dispatch(Time now, RunStats& st);
  bool handle(std::vector<ExecutorEvent>& events, RunStats& st);  // true: re-plan now
  // After the executor drained: true when the run is over (finished or stalled).
  bool drained(RunStats& st);
  Scheduler& scheduler_;
  Executor& executor_;
  Workload& workload_;
  JobPool& pool_;
  Schedule& schedule_;
  std::size_t dispatched_ = 0;
};

}  // namespace rayline

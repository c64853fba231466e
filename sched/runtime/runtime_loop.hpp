// The control loop shared by both engines (docs/architecture.md):
//   Workload --new jobs--> JobPool --> Scheduler.plan(now, k) --> Schedule --> Executor
//      ^------------- finished jobs (measured times, outputs) <----------------'
// The scheduler is invoked when a compute device's timeline runs dry while jobs are
// queued (Sec. 4.2), and whenever new jobs arrive while some device is idle.
#pragma once
#include <functional>
#include <vector>

#include "sched/runtime/executor.hpp"
#include "sched/runtime/fault.hpp"
#include "sched/policy/scheduler.hpp"
#include "sched/runtime/workload.hpp"

namespace rayline {

struct RunStats {
  Time makespan = 0;
  int plan_calls = 0;
  double scheduler_wall_seconds = 0;
  std::uint64_t execs = 0, transfers = 0, evictions = 0;
  bool stalled = false;  // queued jobs left that no device could ever run
  // Faults (docs/faults.md): applied, activities aborted, jobs queued again, jobs lost,
  // activities that failed on their own (a read error) and were retried.
  int faults = 0;
  std::uint64_t aborted = 0, requeued = 0, lost_jobs = 0, retried = 0;
};

class RuntimeLoop {
 public:
  RuntimeLoop(Scheduler& scheduler, Executor& executor, Workload& workload, JobPool& pool, Schedule& schedule)
      : scheduler_(scheduler), executor_(executor), workload_(workload), pool_(pool), schedule_(schedule) {}

  // Runs until the workload is finished and nothing is queued or in flight, or `until`.
  RunStats run(Time until = kNever);
  // Called after every batch of events (progress reporting, metrics sampling).
  std::function<void(Time now, const RunStats&)> on_progress;
  // Faults to inject (docs/faults.md), each at its time; call before run().
  void add_fault(Fault f);
  // Called once each fault was applied and the run re-planned.
  std::function<void(const Fault&, const RunStats&)> on_fault;
  // An activity that fails on its own (an I/O error reading a block) is retried this many
  // times, then the run ends with a std::runtime_error naming it.
  int max_retries = 3;
  // Per activity (by id; shorter when the last ones had none): the E-job whose end the plan
  // that committed it answered, the earliest to finish in the batch of events before that
  // plan, as its end and its duration (end < 0: the plan followed no finished E-job). The
  // renderer fits the loop's latency from a job's start to this end (DeviceGraph::loop).
  // `planned_at`: when that plan ran (the activity was dispatched then); -1: no plan
  // recorded. The renderer fits ControlLoop::wake from it.
  struct Trigger {
    Time end = -1, exec_seconds = 0, planned_at = -1;
  };
  const std::vector<Trigger>& triggers() const { return triggers_; }
  bool record_triggers = false;  // off: triggers() stays empty (the simulator needs none)

 private:
  void plan_and_dispatch(Time now, RunStats& st);
  void plan(Time now, RunStats& st);
  void dispatch_new();  // what the plans committed since the last dispatch, to the executor
  bool handle(std::vector<ExecutorEvent>& events, RunStats& st);  // true: re-plan now
  // After the executor drained: true when the run is over (finished or stalled).
  bool drained(RunStats& st);
  Scheduler& scheduler_;
  Executor& executor_;
  Workload& workload_;
  JobPool& pool_;
  Schedule& schedule_;
  std::size_t dispatched_ = 0;
  // Faults.
  void apply_fault(const Fault& f, RunStats& st);
  void recover(const std::vector<ActivityId>& seeds, const std::vector<DeviceId>& computes,
               const std::vector<MemId>& memories, RunStats& st);
  // The batch's events into the schedule, pool and workload; Failed ones (not already
  // aborted) are appended to `failed`. True when new jobs arrived.
  bool absorb(const std::vector<ExecutorEvent>& events, std::vector<ActivityId>& failed);
  std::vector<Fault> faults_;
  std::size_t next_fault_ = 0;
  std::vector<std::pair<std::int64_t, int>> retries_;  // (block or ~job, failures), small
  Time last_end_ = 0;  // the latest Finished event
  Trigger batch_trigger_;  // the batch's earliest finished E-job, for the next plan
  std::vector<Trigger> triggers_;
};

}  // namespace rayline

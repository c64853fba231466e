#include "sched/runtime/runtime_loop.hpp"

namespace rayline {

void RuntimeLoop::plan_and_dispatch(Time now, RunStats& st) {
  const PlanStats ps = scheduler_.plan(now, pool_, schedule_);
  ++st.plan_calls;
  st.scheduler_wall_seconds += ps.wall_seconds;
  st.execs += static_cast<std::uint64_t>(ps.execs);
  st.transfers += static_cast<std::uint64_t>(ps.transfers);
  st.evictions += static_cast<std::uint64_t>(ps.evictions);
  for (; dispatched_ < schedule_.activity_count(); ++dispatched_)
    executor_.dispatch(static_cast<ActivityId>(dispatched_), schedule_.activity(static_cast<ActivityId>(dispatched_)));
}

bool RuntimeLoop::handle(std::vector<ExecutorEvent>& events, RunStats& st) {
  bool new_jobs = false;
  for (const ExecutorEvent& e : events) {
    switch (e.type) {
      case ExecutorEvent::Type::Started: schedule_.on_started(e.activity, e.time); break;
      case ExecutorEvent::Type::Finished: {
        schedule_.on_finished(e.activity, e.time);
        const Activity& a = schedule_.activity(e.activity);
        if (a.kind == ActivityKind::Exec) {
          pool_.mark_done(a.job);
          const std::size_t q = pool_.queued_count();
          workload_.on_job_finished(a.job, e.time, pool_, schedule_);
          new_jobs = new_jobs || pool_.queued_count() > q;
        }
        break;
      }
      case ExecutorEvent::Type::Failed: schedule_.on_finished(e.activity, e.time); break;
    }
  }
  st.makespan = executor_.now();
  if (on_progress) on_progress(executor_.now(), st);
  // Sec. 4.2: re-plan when a device's timeline ran dry, or new work arrived while idle.
  if (pool_.queued_count() == 0) return false;
  const auto& g = schedule_.graph();
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    if (schedule_.unfinished_on_device(static_cast<DeviceId>(d)) == 0) return true;
  return new_jobs && schedule_.unfinished() == 0;
}

bool RuntimeLoop::drained(RunStats& st) {
  // Nothing in flight. Either we are done, or the workload has more for us.
  if (pool_.queued_count() == 0) workload_.on_idle(executor_.now(), pool_, schedule_);
  if (pool_.queued_count() == 0) return workload_.finished();
  const std::size_t before = schedule_.activity_count();
  plan_and_dispatch(executor_.now(), st);
  if (schedule_.activity_count() == before) {  // queued jobs no device can take
    st.stalled = true;
    return true;
  }
  return false;
}

RunStats RuntimeLoop::run(Time until) {
  RunStats st;
  workload_.start(executor_.now(), pool_, schedule_);
  if (pool_.queued_count() > 0) plan_and_dispatch(executor_.now(), st);
  // The executor runs until nothing is in flight (then the workload may add more, or the
  // run is over) or until `until`; every batch it reports may trigger a plan (Sec. 4.2).
  const Executor::Sink sink = [&](std::vector<ExecutorEvent>& events) {
    if (handle(events, st)) plan_and_dispatch(executor_.now(), st);
  };
  do executor_.run(sink, until);
  while (executor_.now() < until && !drained(st));
  st.makespan = executor_.now();
  return st;
}

}  // namespace rayline

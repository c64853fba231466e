#include "sched/runtime/runtime_loop.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace rayline {

void RuntimeLoop::plan_and_dispatch(Time now, RunStats& st) {
  plan(now, st);
  dispatch_new();
}

void RuntimeLoop::plan(Time now, RunStats& st) {
  const PlanStats ps = scheduler_.plan(now, pool_, schedule_);
  ++st.plan_calls;
  st.scheduler_wall_seconds += ps.wall_seconds;
  st.execs += static_cast<std::uint64_t>(ps.execs);
  st.transfers += static_cast<std::uint64_t>(ps.transfers);
  st.evictions += static_cast<std::uint64_t>(ps.evictions);
  if (record_triggers && dispatched_ < schedule_.activity_count()) {
    triggers_.resize(schedule_.activity_count());
    for (std::size_t id = dispatched_; id < triggers_.size(); ++id) triggers_[id] = {batch_trigger_.end, batch_trigger_.exec_seconds, now};
  }
  batch_trigger_ = {};
}

void RuntimeLoop::dispatch_new() {
  // (Activities aborted before their dispatch, by a fault due at the start, reach the
  // executor too: each engine ends them at once, after their timeline predecessors.)
  for (; dispatched_ < schedule_.activity_count(); ++dispatched_)
    executor_.dispatch(static_cast<ActivityId>(dispatched_), schedule_.activity(static_cast<ActivityId>(dispatched_)));
}

bool RuntimeLoop::absorb(const std::vector<ExecutorEvent>& events, std::vector<ActivityId>& failed) {
  bool new_jobs = false;
  batch_trigger_ = {};
  for (const ExecutorEvent& e : events) {
    switch (e.type) {
      case ExecutorEvent::Type::Started: schedule_.on_started(e.activity, e.time); break;
      case ExecutorEvent::Type::Finished: {
        if (schedule_.activity(e.activity).state == ActivityState::Failed) break;  // aborted meanwhile
        last_end_ = std::max(last_end_, e.time);
        schedule_.on_finished(e.activity, e.time);
        const Activity& a = schedule_.activity(e.activity);
        if (a.kind == ActivityKind::Exec) {
          if (batch_trigger_.end < 0 || e.time < batch_trigger_.end) batch_trigger_ = {e.time, e.time - a.start};
          pool_.mark_done(a.job);
          const std::size_t q = pool_.queued_count();
          workload_.on_job_finished(a.job, e.time, pool_, schedule_);
          new_jobs = new_jobs || pool_.queued_count() > q;
        }
        break;
      }
      case ExecutorEvent::Type::Failed:
        if (executor_.gave_up()) schedule_.on_finished(e.activity, e.time);  // drains, not recovered
        else if (schedule_.activity(e.activity).state != ActivityState::Failed) failed.push_back(e.activity);
        break;
    }
  }
  return new_jobs;
}

bool RuntimeLoop::handle(std::vector<ExecutorEvent>& events, RunStats& st) {
  std::vector<ActivityId> failed;
  bool new_jobs = absorb(events, failed);
  bool recovered = false;
  if (!failed.empty()) {
    // Activities that failed on their own: retried (re-planned) a few times each.
    for (ActivityId id : failed) {
      const Activity& a = schedule_.activity(id);
      const std::int64_t key = a.kind == ActivityKind::Transfer ? a.block : ~static_cast<std::int64_t>(a.job);
      auto it = std::find_if(retries_.begin(), retries_.end(), [key](const auto& r) { return r.first == key; });
      if (it == retries_.end()) it = retries_.insert(retries_.end(), {key, 0});
      if (++it->second > max_retries) {
        if (const std::exception_ptr cause = executor_.cause_of(id)) std::rethrow_exception(cause);
        const std::string why = executor_.why_failed(id);
        throw std::runtime_error(
            (a.kind == ActivityKind::Transfer ? "moving " + pool_.block(a.block).name + " over " +
                                                    schedule_.graph().channels[a.channel].name
                                              : "running " + pool_.job(a.job).name + " on " +
                                                    schedule_.graph().computes[a.device].name) +
            " failed " + std::to_string(it->second) + " times" + (why.empty() ? std::string() : ": " + why));
      }
    }
    st.retried += failed.size();
    recover(failed, {}, {}, st);
    recovered = true;
  }
  while (next_fault_ < faults_.size() && executor_.now() >= faults_[next_fault_].at) {
    apply_fault(faults_[next_fault_++], st);
    recovered = true;
  }
  st.makespan = executor_.now();
  if (on_progress) on_progress(executor_.now(), st);
  // Sec. 4.2: re-plan when a device's timeline ran dry, or new work arrived while idle.
  if (pool_.queued_count() == 0) return false;
  if (recovered) return true;
  const auto& g = schedule_.graph();
  auto idle = [&](DeviceId d) { return schedule_.unfinished_on_device(d) == 0 && schedule_.compute_alive(d); };
  if (!scheduler_.plans_while_idle()) {
    // Only at the events: a device that ran dry in this batch, or new jobs while one is idle.
    for (const ExecutorEvent& e : events)
      if (e.type == ExecutorEvent::Type::Finished && schedule_.activity(e.activity).kind == ActivityKind::Exec &&
          idle(schedule_.activity(e.activity).device))
        return true;
    if (!new_jobs) return false;
  }
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    if (idle(static_cast<DeviceId>(d))) return true;
  return new_jobs && schedule_.unfinished() == 0;
}

void RuntimeLoop::add_fault(Fault f) {
  const auto at = std::upper_bound(faults_.begin(), faults_.end(), f.at, [](Time t, const Fault& x) { return t < x.at; });
  faults_.insert(at, std::move(f));
}

void RuntimeLoop::apply_fault(const Fault& f, RunStats& st) {
  const DeviceGraph& g = schedule_.graph();
  std::vector<DeviceId> computes = f.computes;
  for (MemId m : f.memories)
    for (DeviceId d : g.computes_on(m))
      if (std::find(computes.begin(), computes.end(), d) == computes.end()) computes.push_back(d);
  std::vector<ChannelId> channels;
  for (std::size_t c = 0; c < g.channels.size(); ++c)
    for (MemId m : f.memories)
      if (g.channels[c].from == m || g.channels[c].to == m) {
        channels.push_back(static_cast<ChannelId>(c));
        break;
      }
  // The engine stops the lost devices; what ended meanwhile is taken in first, and what
  // was stopped there is aborted with everything planned on them or waiting for it.
  std::vector<ExecutorEvent> events;
  executor_.halt(computes, channels, events);
  std::vector<ActivityId> stopped;
  absorb(events, stopped);
  recover(stopped, computes, f.memories, st);
  ++st.faults;
  if (on_fault) on_fault(f, st);
}

void RuntimeLoop::recover(const std::vector<ActivityId>& seeds, const std::vector<DeviceId>& computes,
                          const std::vector<MemId>& memories, RunStats& st) {
  const Time now = executor_.now();
  const Schedule::Failure fr = schedule_.fail(now, seeds, computes, memories);
  executor_.abort(fr.aborted);
  st.aborted += fr.aborted.size();
  std::vector<JobId> requeued;
  for (JobId j : fr.jobs)
    if (pool_.state(j) == JobState::Planned) {
      pool_.requeue(j);
      requeued.push_back(j);
    }
  st.requeued += requeued.size();
  if (!requeued.empty()) workload_.on_requeued(now, requeued, pool_, schedule_);
  if (fr.lost.empty()) {
    // Memory devices lost with nothing on them the queue needs: the workload still hears
    // of it (its clients may live there).
    if (!memories.empty()) workload_.on_lost(now, {}, {}, pool_, schedule_);
    return;
  }
  // Lost work: queued jobs reading a lost block, and, transitively, jobs reading what
  // those would have produced.
  std::vector<BlockId> lost_blocks = fr.lost;
  std::vector<char> lost_block(pool_.block_count(), 0);
  for (BlockId b : lost_blocks) lost_block[static_cast<std::size_t>(b)] = 1;
  std::vector<JobId> lost;
  for (bool grew = true; grew;) {
    grew = false;
    std::vector<JobId> now_lost;
    for (JobId j : pool_.queued())
      for (BlockId b : pool_.job(j).inputs)
        if (lost_block[static_cast<std::size_t>(b)]) {
          now_lost.push_back(j);
          break;
        }
    for (JobId j : now_lost) {
      pool_.mark_discarded(j);
      lost.push_back(j);
      for (BlockId o : pool_.job(j).outputs)
        if (!lost_block[static_cast<std::size_t>(o)]) {
          lost_block[static_cast<std::size_t>(o)] = 1;
          lost_blocks.push_back(o);
          grew = true;
        }
    }
  }
  st.lost_jobs += lost.size();
  workload_.on_lost(now, lost, lost_blocks, pool_, schedule_);
}

void Workload::on_lost(Time, const std::vector<JobId>& jobs, const std::vector<BlockId>& blocks, JobPool& pool,
                       Schedule&) {
  if (jobs.empty() && blocks.empty()) return;
  std::string what = blocks.empty() ? std::string() : pool.block(blocks.front()).name;
  if (blocks.size() > 1) what += " and " + std::to_string(blocks.size() - 1) + " more block(s)";
  throw std::runtime_error("lost " + what + " with the failed device" +
                           (jobs.empty() ? std::string() : " (needed by " + pool.job(jobs.front()).name +
                                                               (jobs.size() > 1 ? " and " + std::to_string(jobs.size() - 1) + " more job(s)" : "") + ")") +
                           ": no other copy to recover it from");
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
  if (pool_.queued_count() > 0) plan(executor_.now(), st);
  // Faults due already (at 0 s) apply between the first plan and its dispatch, so no thread
  // of a real engine can start what was planned on a device lost at that time (the plan's
  // work there is planned again); later ones apply at their first batch of events.
  bool faulted = false;
  while (next_fault_ < faults_.size() && executor_.now() >= faults_[next_fault_].at) {
    apply_fault(faults_[next_fault_++], st);
    faulted = true;
  }
  if (faulted && pool_.queued_count() > 0) plan(executor_.now(), st);
  dispatch_new();
  // The executor runs until nothing is in flight (then the workload may add more, or the
  // run is over) or until `until`; every batch it reports may trigger a plan (Sec. 4.2).
  const Executor::Sink sink = [&](std::vector<ExecutorEvent>& events) {
    if (handle(events, st)) plan_and_dispatch(executor_.now(), st);
    // Nothing in flight any more: an engine bounded by `until` may run its clock on to it
    // now (SimGrid does), so this is drained()'s moment: the workload may add work, a
    // policy that plans only for idle devices (Budge) is asked again, and queued jobs that
    // nothing takes are a stall.
    if (until != kNever && schedule_.unfinished() == 0 && executor_.now() < until) (void)drained(st);
  };
  for (const Fault& f : faults_) executor_.wake_at(f.at);
  do executor_.run(sink, until);
  while (executor_.now() < until && !drained(st));
  st.makespan = executor_.now();
  // A wake for a fault keeps the clock going past the last activity; the run ended then.
  if (!faults_.empty() && st.makespan < until) st.makespan = last_end_;
  return st;
}

}  // namespace rayline

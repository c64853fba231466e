#include "sched/gmb_scheduler.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>
#include <set>

namespace rayline {

namespace {
bool nearly_equal(Time a, Time b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(a)); }
}  // namespace

Time GmbScheduler::aging_threshold() const {
  if (opt_.aging >= 0) return opt_.aging;
  return std::max(1.0, 5 * opt_.horizon);
}

const std::array<double, kDataKindCount>& GmbScheduler::bytes_by_kind(JobId j, const JobPool& pool) {
  if (static_cast<std::size_t>(j) >= job_bytes_.size()) {
    job_bytes_.resize(pool.job_count());
    job_bytes_known_.resize(pool.job_count(), 0);
  }
  if (!job_bytes_known_[j]) {
    auto& a = job_bytes_[j];
    a.fill(0);
    for (BlockId b : pool.job(j).inputs)
      a[static_cast<int>(pool.block(b).kind)] += static_cast<double>(pool.block(b).bytes);
    job_bytes_known_[j] = 1;
  }
  return job_bytes_[j];
}

Time GmbScheduler::exec_estimate(JobId j, DeviceId d, const JobPool& pool, const Schedule& s) {
  const Job& job = pool.job(j);
  const ExecCoefficients& k = s.graph().timing.at(d, job.type);
  const auto& bytes = bytes_by_kind(j, pool);
  double exec = 0;
  bool any = false;
  for (int i = 0; i < kDataKindCount; ++i) {
    exec += k.rate[i] * bytes[i];
    any = any || bytes[i] > 0;
  }
  return any ? exec + k.setup : 0;  // Eq. 2
}

GmbScheduler::Choice GmbScheduler::evaluate(JobId j, DeviceId d, Time ready, Time now, const JobPool& pool,
                                            const Schedule& s) {
  Choice c;
  const Job& job = pool.job(j);
  if (!s.graph().timing.supports(d, job.type)) return c;
  const MemId m = s.graph().computes[d].memory;
  if (std::binary_search(blocked_pairs_.begin(), blocked_pairs_.end(), std::make_pair(j, m))) return c;
  const Time start = placer_->earliest_start(j, d, ready, s);
  if (start == kNever) return c;
  c.job = j;
  c.start = start;
  c.created = job.created;
  const Time aging = aging_threshold();
  c.aged = aging != kNever && now - job.created >= aging;
  if (opt_.granularity_tiebreak) {
    const Time exec = exec_estimate(j, d, pool, s);
    c.granularity = exec > 0 ? s.graph().timing.setup_time(d, job.type) / exec : 0;
  }
  return c;
}

// Sec. 4.3: the job that can start earliest on d (smallest fetching overhead), ties by
// granularity T_SETUP/T_EXEC; aged jobs first.
GmbScheduler::Choice GmbScheduler::select(DeviceId d, Time ready, Time now, const JobPool& pool,
                                          const Schedule& s) {
  Choice best;
  for (JobId j : pool.queued()) {
    if (!deferred_.empty() && std::find(deferred_.begin(), deferred_.end(), j) != deferred_.end()) continue;
    const Choice c = evaluate(j, d, ready, now, pool, s);
    if (c.job == kNone) continue;
    bool better;
    if (best.job == kNone) better = true;
    else if (c.aged != best.aged) better = c.aged;
    else if (c.aged && c.created != best.created) better = c.created < best.created;
    else if (!nearly_equal(c.start, best.start)) better = c.start < best.start;
    else better = c.granularity < best.granularity && !nearly_equal(c.granularity, best.granularity);
    if (better) best = c;
  }
  return best;
}

// completion_aware: would another device finish this job earlier than d, given when it
// is free and when the inputs could reach it?
bool GmbScheduler::better_elsewhere(const Choice& c, DeviceId d, const JobPool& pool, const Schedule& s) {
  if (c.aged) return false;
  const Time finish_here = c.start + exec_estimate(c.job, d, pool, s);
  const DeviceGraph& g = s.graph();
  for (std::size_t o = 0; o < g.computes.size(); ++o) {
    const auto od = static_cast<DeviceId>(o);
    if (od == d || !g.timing.supports(od, pool.job(c.job).type)) continue;
    const Time ready_o = std::max(now_, s.device_timeline(od).busy_until);
    if (ready_o >= finish_here) continue;
    const Time start_o = placer_->earliest_start(c.job, od, ready_o, s);
    if (start_o == kNever) continue;
    if (start_o + exec_estimate(c.job, od, pool, s) < finish_here * (1 - 1e-9)) return true;
  }
  return false;
}

bool GmbScheduler::commit(const Choice& c, DeviceId d, Time ready, Time now, JobPool& pool, Schedule& s,
                          PlanStats& st) {
  if (placer_->place(c.job, d, ready, now, pool, s, st)) return true;
  const auto key = std::make_pair(c.job, s.graph().computes[d].memory);
  blocked_pairs_.insert(std::upper_bound(blocked_pairs_.begin(), blocked_pairs_.end(), key), key);
  return false;
}

PlanStats GmbScheduler::plan(Time now, JobPool& pool, Schedule& s) {
  const auto t0 = std::chrono::steady_clock::now();
  PlanStats st;
  if (bound_ != &s || !placer_) {
    placer_ = std::make_unique<Placer>(s);
    bound_ = &s;
  }
  s.reproject(now);
  placer_->finder().clear();
  placer_->finder().set_now(now);
  blocked_pairs_.clear();
  const std::uint64_t searches0 = placer_->finder().searches(), hits0 = placer_->finder().hits();
  now_ = now;
  const Time end = now + opt_.horizon;
  const DeviceGraph& g = s.graph();
  using Item = std::pair<Time, DeviceId>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> devices;
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    devices.emplace(std::max(now, s.device_timeline(static_cast<DeviceId>(d)).busy_until), static_cast<DeviceId>(d));
  while (!devices.empty() && pool.queued_count() > 0) {
    const auto [ready, d] = devices.top();
    devices.pop();
    if (ready >= end) break;  // every device is planned up to now + k
    deferred_.clear();
    for (;;) {
      const Choice c = select(d, ready, now, pool, s);
      if (c.job == kNone) break;  // nothing this device can run: it leaves this round
      if (opt_.completion_aware && c.start > ready && better_elsewhere(c, d, pool, s)) {
        deferred_.push_back(c.job);
        continue;
      }
      if (commit(c, d, ready, now, pool, s, st)) {
        devices.emplace(std::max(now, s.device_timeline(d).busy_until), d);
        break;
      }
    }
  }
  st.path_searches = placer_->finder().searches() - searches0;
  st.path_cache_hits = placer_->finder().hits() - hits0;
  st.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace rayline

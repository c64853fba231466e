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

// Sec. 4.3: the job that can start earliest on d (smallest fetching overhead), ties by
// granularity T_SETUP/T_EXEC; aged jobs first.
GmbScheduler::Choice GmbScheduler::select(DeviceId d, Time ready, Time now, const JobPool& pool,
                                          const Schedule& s) {
  const DeviceGraph& g = s.graph();
  const MemId m = g.computes[d].memory;
  const Time aging = aging_threshold();
  Choice best;
  for (JobId j : pool.queued()) {
    const Job& job = pool.job(j);
    if (!g.timing.supports(d, job.type)) continue;
    if (std::binary_search(blocked_pairs_.begin(), blocked_pairs_.end(), std::make_pair(j, m))) continue;
    Time arrive = s.after_deps_ready(j);
    if (arrive == kNever) continue;
    for (BlockId b : job.inputs) {
      const Copy* c = s.copy_at(b, m);
      arrive = std::max(arrive, c ? s.copy_ready(*c) : placer_->finder().arrival(b, m));
      if (arrive == kNever) break;
    }
    if (arrive == kNever) continue;
    Choice c;
    c.job = j;
    c.start = std::max(ready, arrive);
    c.created = job.created;
    c.aged = aging != kNever && now - job.created >= aging;
    if (opt_.granularity_tiebreak) {
      const ExecCoefficients& k = g.timing.at(d, job.type);
      const auto& bytes = bytes_by_kind(j, pool);
      double exec = 0;
      for (int i = 0; i < kDataKindCount; ++i) exec += k.rate[i] * bytes[i];
      exec += (exec > 0 || job.inputs.empty()) ? k.setup : 0;
      c.granularity = exec > 0 ? k.setup / exec : 0;
    }
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
    for (;;) {
      const Choice c = select(d, ready, now, pool, s);
      if (c.job == kNone) break;  // nothing this device can run: it leaves this round
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

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

std::string GmbScheduler::describe() const {
  const Time a = aging_threshold();
  return "gmb{k=" + std::to_string(opt_.horizon) + "s; aging=" + (a == kNever ? std::string("off") : std::to_string(a) + "s") +
         "; granularity_tiebreak=" + (opt_.granularity_tiebreak ? "1" : "0") +
         "; completion_aware=" + (opt_.completion_aware ? "1" : "0") + "}";
}

Time GmbScheduler::aging_threshold() const {
  if (opt_.aging >= 0) return opt_.aging;
  return std::max(1.0, 5 * opt_.horizon);
}

Time GmbScheduler::exec_estimate(JobId j, DeviceId d, const JobPool& pool, const Schedule& s) {
  const Job& job = pool.job(j);
  const ExecCoefficients& k = s.graph().timing.at(d, job.type);
  double exec = 0;
  bool any = false;
  for (BlockId b : job.inputs) {
    const DataBlock& blk = pool.block(b);
    exec += k.rate[static_cast<int>(blk.kind)] * static_cast<double>(blk.bytes);
    any = any || blk.bytes > 0;
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

// Sec. 4.3 order: aged jobs first (oldest first); then the earliest possible start (the
// smallest fetching overhead); ties to the smallest T_SETUP/T_EXEC (highest granularity);
// then the job that entered the queue first.
bool GmbScheduler::prefer(const Choice& c, const Choice& best) const {
  if (best.job == kNone) return true;
  if (c.aged != best.aged) return c.aged;
  if (c.aged && c.created != best.created) return c.created < best.created;
  if (!nearly_equal(c.start, best.start)) return c.start < best.start;
  if (!nearly_equal(c.granularity, best.granularity)) return c.granularity < best.granularity;
  return c.job < best.job;
}

GmbScheduler::Choice GmbScheduler::select(DeviceId d, Time ready, Time now, const JobPool& pool,
                                          const Schedule& s) {
  if (!any_aged_) return select_pruned(d, ready, now, pool, s);
  Choice best;
  for (JobId j : pool.queued()) {
    if (!deferred_.empty() && std::find(deferred_.begin(), deferred_.end(), j) != deferred_.end()) continue;
    const Choice c = evaluate(j, d, ready, now, pool, s);
    if (c.job != kNone && prefer(c, best)) best = c;
  }
  return best;
}

void GmbScheduler::build_index(Time now, const JobPool& pool) {
  buckets_.clear();
  bucket_of_block_.assign(pool.block_count(), -1);
  const Time aging = aging_threshold();
  any_aged_ = false;
  for (JobId j : pool.queued()) {
    const Job& job = pool.job(j);
    any_aged_ = any_aged_ || (aging != kNever && now - job.created >= aging);
    BlockId key = kNone;
    for (BlockId b : job.inputs)
      if (key == kNone || pool.block(b).bytes > pool.block(key).bytes) key = b;
    if (key == kNone) key = static_cast<BlockId>(pool.block_count());  // no inputs: its own bucket
    if (static_cast<std::size_t>(key) >= bucket_of_block_.size()) bucket_of_block_.resize(static_cast<std::size_t>(key) + 1, -1);
    if (bucket_of_block_[key] < 0) {
      bucket_of_block_[key] = static_cast<std::int32_t>(buckets_.size());
      buckets_.push_back({key, {}});
    }
    buckets_[static_cast<std::size_t>(bucket_of_block_[key])].jobs.push_back(j);
  }
}

// Same choice as the full scan, visiting buckets in order of a lower bound on their start
// (FetchBound on the key block), and evaluating exactly (SDC) only the jobs whose own
// bound could still win.
GmbScheduler::Choice GmbScheduler::select_pruned(DeviceId d, Time ready, Time now, const JobPool& pool,
                                                 const Schedule& s) {
  const DeviceGraph& g = s.graph();
  const MemId m = g.computes[d].memory;
  order_.clear();
  for (std::size_t i = 0; i < buckets_.size(); ++i) {
    Bucket& bk = buckets_[i];
    std::erase_if(bk.jobs, [&](JobId j) { return pool.state(j) != JobState::Queued; });
    if (bk.jobs.empty()) continue;
    Time lb = ready;
    if (static_cast<std::size_t>(bk.key) < pool.block_count())
      lb = std::max(lb, bound_time_->lower_bound(s, bk.key, m, now));
    if (lb == kNever) continue;
    order_.emplace_back(lb, static_cast<std::int32_t>(i));
  }
  std::sort(order_.begin(), order_.end());
  Choice best;
  auto loses = [&](Time lb) { return best.job != kNone && lb > best.start && !nearly_equal(lb, best.start); };
  const Time aging = aging_threshold();
  for (const auto& [blb, i] : order_) {
    if (loses(blb)) break;
    const Bucket& bk = buckets_[static_cast<std::size_t>(i)];
    const bool has_key = static_cast<std::size_t>(bk.key) < pool.block_count();
    // The key block's exact SDC arrival (one cached search per block and memory device).
    Time key_at = ready;
    if (has_key) {
      if (const Copy* c = s.copy_at(bk.key, m)) {
        key_at = std::max(ready, s.copy_ready(*c));
      } else {
        // When the best direct hop meets the lower bound, that is SDC's answer too.
        const Time ub = bound_time_->direct_upper_bound(s, bk.key, m, now);
        const Time at = ub <= blb * (1 + 1e-12) ? ub : placer_->finder().arrival(bk.key, m);
        key_at = std::max(ready, at);
      }
    }
    if (key_at == kNever || loses(key_at)) continue;
    for (JobId j : bk.jobs) {
      if (!deferred_.empty() && std::find(deferred_.begin(), deferred_.end(), j) != deferred_.end()) continue;
      const Job& job = pool.job(j);
      if (!g.timing.supports(d, job.type)) continue;
      if (std::binary_search(blocked_pairs_.begin(), blocked_pairs_.end(), std::make_pair(j, m))) continue;
      Time start = std::max(key_at, s.after_deps_ready(j));
      if (has_key && !s.copy_at(bk.key, m) && !Placer::may_fetch(job, bk.key, s)) continue;
      for (BlockId b : job.inputs) {
        if (start == kNever || loses(start)) break;
        if (has_key && b == bk.key) continue;
        if (!s.copy_at(b, m) && !Placer::may_fetch(job, b, s)) {
          start = kNever;
          break;
        }
        // Exact without a search when a direct hop already lands by `start`.
        if (bound_time_->direct_upper_bound(s, b, m, now) <= start) continue;
        if (loses(bound_time_->lower_bound(s, b, m, now))) {
          start = kNever;
          break;
        }
        const Copy* c = s.copy_at(b, m);
        start = std::max(start, c ? s.copy_ready(*c) : placer_->finder().arrival(b, m));
      }
      if (start == kNever || loses(start)) continue;
      Choice c;
      c.job = j;
      c.start = start;
      c.created = job.created;
      c.aged = aging != kNever && now - job.created >= aging;
      if (opt_.granularity_tiebreak) {
        const Time exec = exec_estimate(j, d, pool, s);
        c.granularity = exec > 0 ? g.timing.setup_time(d, job.type) / exec : 0;
      }
      if (prefer(c, best)) best = c;
    }
  }
  return best;
}

// completion_aware: would another device finish this job earlier than d, given when it
// is free and when the inputs could reach it?
bool GmbScheduler::better_elsewhere(const Choice& c, DeviceId d, const JobPool& pool, const Schedule& s) {
  if (c.aged) return false;
  const Time finish_here = c.start + exec_estimate(c.job, d, pool, s);
  const DeviceGraph& g = s.graph();
  const Job& job = pool.job(c.job);
  for (std::size_t o = 0; o < g.computes.size(); ++o) {
    const auto od = static_cast<DeviceId>(o);
    if (od == d || !g.timing.supports(od, job.type)) continue;
    const Time ready_o = std::max(now_, s.device_timeline(od).busy_until);
    const Time exec_o = exec_estimate(c.job, od, pool, s);
    if (ready_o + exec_o >= finish_here) continue;  // cheap prunes first,
    Time lb = ready_o;
    for (BlockId b : job.inputs) lb = std::max(lb, bound_time_->lower_bound(s, b, g.computes[od].memory, now_));
    if (lb + exec_o >= finish_here) continue;  // then FetchBound, then the exact SDC start
    const Time start_o = placer_->earliest_start(c.job, od, ready_o, s);
    if (start_o != kNever && start_o + exec_o < finish_here * (1 - 1e-9)) return true;
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
    bound_time_ = std::make_unique<FetchBound>(s.graph());
    bound_ = &s;
  }
  s.reproject(now);
  placer_->finder().clear();
  placer_->finder().set_now(now);
  blocked_pairs_.clear();
  build_index(now, pool);
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
      // At most 16 deferrals per placement keep the refinement's cost bounded.
      if (opt_.completion_aware && c.start > ready && deferred_.size() < 16 && better_elsewhere(c, d, pool, s)) {
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

#include "sched/policy/gmb/gmb_scheduler.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>

namespace rayline {

namespace {
// (An infinite time is equal only to itself: without that, kNever would tie with every
// best start, and a bound of kNever would never lose.)
bool nearly_equal(Time a, Time b) {
  if (std::isinf(a) || std::isinf(b)) return a == b;
  return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(a));
}
}  // namespace

std::string GmbScheduler::describe() const {
  const Time a = aging_threshold();
  return "gmb{k=" + std::to_string(opt_.horizon) + "s; aging=" + (a == kNever ? std::string("off") : std::to_string(a) + "s") +
         (opt_.adaptive_aging ? "; adaptive_aging=1" : "") +
         "; granularity_tiebreak=" + (opt_.granularity_tiebreak ? "1" : "0") +
         "; completion_aware=" + (opt_.completion_aware ? "1" : "0") +
         (opt_.cell_nodes > 0 ? "; cell_nodes=" + std::to_string(opt_.cell_nodes) : "") + "}";
}

// What the graph-only structures depend on: memory devices (capacities), channels (Eq. 1
// coefficients, endpoints, resources). FNV-1a over their values.
std::uint64_t GmbScheduler::fingerprint(const DeviceGraph& g) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](std::uint64_t v) {
    h ^= v;
    h *= 1099511628211ull;
  };
  auto mixd = [&mix](double v) { mix(std::bit_cast<std::uint64_t>(v)); };
  mix(g.memories.size());
  for (const MemoryDevice& m : g.memories) mix(static_cast<std::uint64_t>(m.capacity));
  mix(g.channels.size());
  for (const Channel& c : g.channels) {
    mix(static_cast<std::uint64_t>(c.from) << 32 | static_cast<std::uint32_t>(c.to));
    mixd(c.latency);
    mixd(c.bandwidth);
    for (ResourceId r : c.resources) mix(static_cast<std::uint64_t>(r));
  }
  mix(g.computes.size());
  return h;
}

Time GmbScheduler::aging_threshold() const {
  if (opt_.aging >= 0) return opt_.aging;
  return std::max(1.0, 5 * opt_.horizon);
}

GmbScheduler::Choice GmbScheduler::evaluate(JobId j, DeviceId d, Time ready, Time now, const JobPool& pool,
                                            const Schedule& s) {
  Choice c;
  const Job& job = pool.job(j);
  if (!s.graph().timing.supports(d, job.type)) return c;
  const MemId m = s.graph().computes[d].memory;
  if (!cells_.eligible(j, m)) return c;
  if (std::binary_search(blocked_pairs_.begin(), blocked_pairs_.end(), std::make_pair(j, m))) return c;
  const Time start = placer_->earliest_start(j, d, ready, s);
  if (start == kNever) return c;
  c.job = j;
  c.set_start(start);
  c.created = job.created;
  const Time aging = aging_now_;
  c.aged = aging != kNever && now - job.created >= aging;
  if (opt_.granularity_tiebreak) {
    const Time exec = Placer::exec_estimate(j, d, s);
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
  const bool any_aged = !aged_.empty();
  if (any_aged && opt_.reference_selection) {  // the plain scan: prefer() over every queued job
    Choice best;
    for (JobId j : pool.queued()) {
      if (deferred(j)) continue;
      const Choice c = evaluate(j, d, ready, now, pool, s);
      if (c.job != kNone && prefer(c, best)) best = c;
    }
    return best;
  }
  if (any_aged) {
    // Sec. 4.3 aging: an aged job beats every other, an older one every younger one, so
    // the scan's choice is the prefer() fold over the oldest aged jobs that can run on d,
    // in queue order (aged_ is stably sorted by age, and planning keeps queue order).
    // Only when no aged job can run on d does the choice fall to the non-aged jobs, where
    // the aged ones (all unable) change nothing: the usual selection.
    while (aged_head_ < aged_.size() && pool.state(aged_[aged_head_]) != JobState::Queued) ++aged_head_;
    for (std::size_t k = aged_head_; k < aged_.size();) {
      const Time created = pool.job(aged_[k]).created;
      Choice best;
      for (; k < aged_.size() && pool.job(aged_[k]).created == created; ++k) {
        const JobId j = aged_[k];
        if (pool.state(j) != JobState::Queued) continue;
        if (deferred(j)) continue;
        const Choice c = evaluate(j, d, ready, now, pool, s);
        if (c.job != kNone && prefer(c, best)) best = c;
      }
      if (best.job != kNone) return best;
    }
  }
  if (opt_.reference_selection) return select_pruned(d, ready, now, pool, s);
  return select_indexed(d, ready, now, pool, s);
}

void GmbScheduler::build_index(Time now, const JobPool& pool) {
  // Only the last pass's entries are reset: a long path-tracing run has ~10^6 jobs and
  // blocks (every ray queue is one) and plans every time a device runs dry.
  for (Bucket& bk : buckets_) {
    bucket_of_block_[static_cast<std::size_t>(bk.key)] = -1;
    bk.jobs.clear();
    spare_jobs_.push_back(std::move(bk.jobs));
  }
  buckets_.clear();
  for (JobId j : indexed_jobs_) bucket_of_job_[static_cast<std::size_t>(j)] = -1;
  indexed_jobs_.clear();
  if (bucket_of_block_.size() < pool.block_count()) bucket_of_block_.resize(pool.block_count(), -1);
  if (bucket_of_job_.size() < pool.job_count()) bucket_of_job_.resize(pool.job_count(), -1);
  aging_now_ = aging_threshold();
  if (opt_.adaptive_aging && aging_now_ != kNever && pool.queued_count() > 0) {
    // Adaptive aging (Rayline's option): a job is aged only once it has also waited twice
    // as long as the median queued job, so under saturation, where every job waits, only
    // the outliers jump the queue and GMB keeps its locality.
    ages_.clear();
    for (JobId j : pool.queued()) ages_.push_back(now - pool.job(j).created);
    // (The lower median: with two queued jobs, the younger one's wait.)
    auto mid = ages_.begin() + static_cast<std::ptrdiff_t>((ages_.size() - 1) / 2);
    std::nth_element(ages_.begin(), mid, ages_.end());
    aging_now_ = std::max(aging_now_, 2 * *mid);
  }
  const Time aging = aging_now_;
  aged_.clear();
  aged_head_ = 0;
  for (JobId j : pool.queued()) {
    const Job& job = pool.job(j);
    if (aging != kNever && now - job.created >= aging) aged_.push_back(j);
    BlockId key = kNone;
    for (BlockId b : job.inputs)
      if (key == kNone || pool.block(b).bytes > pool.block(key).bytes) key = b;
    if (key == kNone) key = static_cast<BlockId>(pool.block_count());  // no inputs: its own bucket
    if (static_cast<std::size_t>(key) >= bucket_of_block_.size()) bucket_of_block_.resize(static_cast<std::size_t>(key) + 1, -1);
    if (bucket_of_block_[key] < 0) {
      bucket_of_block_[key] = static_cast<std::int32_t>(buckets_.size());
      buckets_.push_back({key, {}, 0});
      if (!spare_jobs_.empty()) {
        buckets_.back().jobs = std::move(spare_jobs_.back());
        spare_jobs_.pop_back();
      }
    }
    Bucket& bk = buckets_[static_cast<std::size_t>(bucket_of_block_[key])];
    bk.jobs.push_back(j);
    ++bk.queued;
    bucket_of_job_[j] = bucket_of_block_[key];
    indexed_jobs_.push_back(j);
  }
  // Oldest first; equally old ones in queue order.
  std::stable_sort(aged_.begin(), aged_.end(), [&](JobId a, JobId b) { return pool.job(a).created < pool.job(b).created; });
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
  auto loses = [&](Time lb) { return best.loses(lb); };
  const Time aging = aging_now_;
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
        Time at = ub;
        if (!(ub <= blb * (1 + 1e-12))) {
          // The exact arrival from a search cut at losing labels where SDC searches (kNever
          // when it loses: skipped below either way), else from the tree.
          at = cut_searchable(s, bk.key, m) && !placer_->finder().scene_from_origin_or_local()
                   ? placer_->finder().arrival_within(bk.key, m, -kNever, loses)
                   : placer_->finder().arrival(bk.key, m);
        }
        key_at = std::max(ready, at);
      }
    }
    if (key_at == kNever || loses(key_at)) continue;
    for (JobId j : bk.jobs) {
      if (deferred(j)) continue;
      const Job& job = pool.job(j);
      if (!g.timing.supports(d, job.type)) continue;
      if (!cells_.eligible(j, m)) continue;
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
        // (Not memoised: the same value, without a memo slot per ray queue.)
        if (loses(bound_time_->lower_bound_once(s, b, m, now))) {
          start = kNever;
          break;
        }
        const Copy* c = s.copy_at(b, m);
        start = std::max(start, c                          ? s.copy_ready(*c)
                                : cut_searchable(s, b, m) ? placer_->finder().arrival_within(b, m, start, loses)
                                                           : placer_->finder().arrival(b, m));
      }
      if (start == kNever || loses(start)) continue;
      Choice c;
      c.job = j;
      c.set_start(start);
      c.created = job.created;
      c.aged = aging != kNever && now - job.created >= aging;
      if (opt_.granularity_tiebreak) {
        const Time exec = Placer::exec_estimate(j, d, s);
        c.granularity = exec > 0 ? g.timing.setup_time(d, job.type) / exec : 0;
      }
      if (prefer(c, best)) best = c;
    }
  }
  return best;
}

// ---- incremental selection -------------------------------------------------------------
// Chooses exactly what select_pruned() chooses. Both fold the same per-job start times
// (identical arithmetic: the key block's arrival with the same one/two-hop shortcut, the
// same per-input tests) with prefer(); they differ only in which buckets and jobs they
// look at, and skip only what cannot win. Under nearly_equal()'s tolerance the fold is
// order-independent unless two compared values are within 1e-12 but different; that is
// detected (near_tie_) and the selection is then redone by select_pruned().

// Choice::loses()'s threshold: above `start + 1e-11 max(1, |start|)` a time t > start is never
// nearly_equal() to start: t - start > 1e-11 M (M = max(1, |start|)) exceeds
// 1e-12 max(1, t) <= 1e-12 (M + t - start) tenfold, far beyond rounding. Between the two
// the exact test decides.
bool GmbScheduler::Choice::nearly_at_start(Time t) const { return nearly_equal(t, start); }

bool GmbScheduler::prefer_checked_full(const Choice& c, const Choice& best) {
  if (best.job != kNone && c.aged == best.aged) {
    if (nearly_equal(c.start, best.start)) {
      if (c.start != best.start) near_tie_ = true;
      else if (nearly_equal(c.granularity, best.granularity) && c.granularity != best.granularity) near_tie_ = true;
    }
  }
  return prefer(c, best);
}

void GmbScheduler::build_classes(const Schedule& s) {
  const DeviceGraph& g = s.graph();
  // The classes depend on the Eq. 2 coefficients alone (refitted between plans at run
  // time): kept while their bytes are the same (a byte compare; different bytes for equal
  // values, such as -0 and +0, only rebuild them).
  const std::span<const ExecCoefficients> coef = g.timing.coefficients();
  const std::size_t n_bytes = coef.size_bytes();
  if (classes_ > 0 && class_of_device_.size() == g.computes.size() && class_coef_.size() == n_bytes &&
      (n_bytes == 0 || std::memcmp(class_coef_.data(), coef.data(), n_bytes) == 0))
    return;
  class_coef_.resize(n_bytes);
  if (n_bytes > 0) std::memcpy(class_coef_.data(), coef.data(), n_bytes);
  const auto same = [&](DeviceId a, DeviceId b) {
    for (int t = 0; t < g.timing.job_types(); ++t) {
      const ExecCoefficients& x = g.timing.at(a, static_cast<JobTypeId>(t));
      const ExecCoefficients& y = g.timing.at(b, static_cast<JobTypeId>(t));
      if (x.supported != y.supported || x.setup != y.setup || x.rate != y.rate) return false;
    }
    return true;
  };
  std::vector<DeviceId>& reps = class_reps_;
  reps.clear();
  class_of_device_.assign(g.computes.size(), -1);
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const auto dd = static_cast<DeviceId>(d);
    for (std::size_t k = 0; k < reps.size() && class_of_device_[d] < 0; ++k)
      if (same(dd, reps[k])) class_of_device_[d] = static_cast<std::int32_t>(k);
    if (class_of_device_[d] < 0) {
      class_of_device_[d] = static_cast<std::int32_t>(reps.size());
      reps.push_back(dd);
    }
  }
  classes_ = static_cast<std::int32_t>(reps.size());
}

double GmbScheduler::granularity(JobId j, DeviceId d, const JobPool& pool, const Schedule& s) {
  if (!opt_.granularity_tiebreak) return 0;
  const Time exec = Placer::exec_estimate(j, d, s);
  return exec > 0 ? s.graph().timing.setup_time(d, pool.job(j).type) / exec : 0;
}

// Bucket i's jobs in (T_SETUP/T_EXEC on d, id) order: among jobs that start at the same
// time the first one wins (Sec. 4.3 tie-break), so a scan in this order can stop at the
// first job that starts as early as the key block allows.
const GmbScheduler::Sorted& GmbScheduler::sorted_jobs(std::int32_t i, DeviceId d, MemId m, const JobPool& pool,
                                                      const Schedule& s) {
  const std::size_t cell = cells_.flat() ? 0 : static_cast<std::size_t>(cells_.cell_of_memory(m));
  Sorted& so = sorted_[(static_cast<std::size_t>(i) * static_cast<std::size_t>(cells_.count()) + cell) *
                           static_cast<std::size_t>(classes_) +
                       static_cast<std::size_t>(class_of_device_[d])];
  if (so.built) {
    // Planned jobs leave lazily: those in front at once, the rest once they are the
    // majority.
    while (so.head < so.jobs.size() && pool.state(so.jobs[so.head].second) != JobState::Queued) ++so.head;
    const Bucket& bk = buckets_[static_cast<std::size_t>(i)];
    if (so.jobs.size() > 8 && static_cast<std::size_t>(bk.queued) * 2 < so.jobs.size() - so.head) {
      so.jobs.erase(so.jobs.begin(), so.jobs.begin() + static_cast<std::ptrdiff_t>(so.head));
      so.head = 0;
      std::erase_if(so.jobs, [&](const auto& e) { return pool.state(e.second) != JobState::Queued; });
    }
    return so;
  }
  so.built = true;
  so.head = 0;
  so.jobs.clear();
  for (JobId j : buckets_[static_cast<std::size_t>(i)].jobs)
    if (pool.state(j) == JobState::Queued && cells_.eligible(j, m)) so.jobs.emplace_back(granularity(j, d, pool, s), j);
  std::sort(so.jobs.begin(), so.jobs.end());
  for (std::size_t k = 1; k < so.jobs.size(); ++k)
    if (so.jobs[k].first != so.jobs[k - 1].first && nearly_equal(so.jobs[k].first, so.jobs[k - 1].first)) so.monotone = false;
  return so;
}

// Lower bound on when any job of group g can start on m: a lower bound on the SDC arrival
// of the group's smallest block (arrivals are monotone in size within a group): FetchBound
// (Eq. 3's last hop) and the exact arrivals recorded so far (ArrivalBound). No search: the
// exact arrival is computed when the group is visited (evaluate_bucket) and recorded.
Time GmbScheduler::group_key(std::int32_t g, MemId m, Time now, const Schedule& s) {
  const BlockId ref = arrival_bound_->smallest(s, g);
  if (ref == kNone) return kNever;
  if (const Copy* c = s.copy_at(ref, m)) return std::max(now, s.copy_ready(*c));
  // (ref is g's smallest current member: ArrivalBound::bound(s, ref, m) without finding
  // its group and smallest member again. A group still at version 0 has no record that
  // bound() could use: every record for a member since it joined counts.)
  const Time recorded = arrival_bound_->version(g) == 0 ? -kNever : arrival_bound_->bound(s, ref, m, g, ref);
  return std::max({bound_time_->free_run_bound(s, ref, m, now), recorded, placer_->finder().known_lower_bound(ref, m)});
}

// Exact SDC arrival of input b at m folded into `start` (max), or kNever once it `loses`.
// Same result as select_pruned()'s per-input step (one/two-hop upper bound, lower bound,
// search), with one search cut at losing labels instead. Where the upper bound is not an
// SDC path (an unmovable block, a destination smaller than the block) the step is kept
// as it was, so the choice stays the same.
template <class Loses>
Time GmbScheduler::fold_input(BlockId b, MemId m, Time start, Time now, const Schedule& s, const Loses& loses,
                              Time& lost_at) {
  if (const Copy* c = s.copy_at(b, m)) {
    const Time r = std::max(now, s.copy_ready(*c));
    if (r <= start) return start;
    if (loses(r)) return lost_at = r, kNever;
    return std::max(start, s.copy_ready(*c));
  }
  if (cut_searchable(s, b, m))
    return std::max(start, placer_->finder().arrival_within(b, m, start, loses, &lost_at));
  if (bound_time_->direct_upper_bound(s, b, m, now) <= start) return start;
  if (const Time lb = bound_time_->lower_bound_once(s, b, m, now); loses(lb)) return lost_at = lb, kNever;
  return std::max(start, placer_->finder().arrival(b, m));
}

// The group's buckets, smallest key block first, until the key block's bound loses: every
// larger block of the group arrives no earlier. False when no bucket has queued jobs.
bool GmbScheduler::visit_group(std::int32_t g, DeviceId d, MemId m, Time ready, Time now, const JobPool& pool,
                               const Schedule& s, Choice& best) {
  auto loses = [&](Time lb) { return best.loses(lb); };
  bool any = false;
  const auto& members = arrival_bound_->members(g);
  // (No commit happens while selecting: g's smallest current member stays the same.)
  const std::size_t k0 = arrival_bound_->first_current(s, g);
  const BlockId first = k0 < members.size() ? members[k0].second : kNone;
  for (std::size_t k = k0; k < members.size(); ++k) {
    const BlockId b = members[k].second;
    if (arrival_bound_->group(s, b) != g) continue;  // left the group
    const std::int32_t i = bucket_of_block_[b];
    if (i < 0 || open(i, m) == 0) continue;  // every job planned, or infeasible on m
    any = true;
    // The group's records bound every larger member too. (FetchBound's lower bound is no
    // cut here: the arrival's own floor and memo answer "lost" as cheaply, and each lost
    // key is recorded, so the next member's bound breaks the scan.)
    if (arrival_bound_->version(g) != 0 && loses(std::max(ready, arrival_bound_->bound(s, b, m, g, first)))) break;
    evaluate_bucket(i, d, m, ready, now, pool, s, best);
  }
  return any;
}

// The body of select_pruned()'s bucket loop, for one bucket.
void GmbScheduler::evaluate_bucket(std::int32_t i, DeviceId d, MemId m, Time ready, Time now, const JobPool& pool,
                                   const Schedule& s, Choice& best) {
  const DeviceGraph& g = s.graph();
  const Bucket& bk = buckets_[static_cast<std::size_t>(i)];
  auto loses = [&](Time lb) { return best.loses(lb); };
  const bool has_key = static_cast<std::size_t>(bk.key) < pool.block_count();
  // FetchBound's lower bound on the key block (select_pruned()'s `blb`), where its
  // arithmetic needs it.
  auto lower = [&] { return std::max(ready, bound_time_->lower_bound(s, bk.key, m, now)); };
  Time key_at = ready;
  const Copy* key_copy = has_key ? s.copy_at(bk.key, m) : nullptr;
  if (has_key) {
    if (key_copy) {
      key_at = std::max(ready, s.copy_ready(*key_copy));
    } else {
      if (cut_searchable(s, bk.key, m) && !placer_->finder().scene_from_origin_or_local()) {
        // select_pruned(): the one/two-hop upper bound when it meets the lower bound, else
        // the SDC arrival. Both are the arrival when a best path has at most two hops.
        Time proven = kNever;
        int hops = 0;
        const Time a = placer_->finder().arrival_within(bk.key, m, -kNever, loses, &proven, &hops);
        if (a == kNever) {  // loses (or no path)
          arrival_bound_->record(s, bk.key, m, proven);
          return;
        }
        Time at = a;
        if (hops > 2)
          if (const Time ub = bound_time_->direct_upper_bound(s, bk.key, m, now); ub <= lower() * (1 + 1e-12)) at = ub;
        arrival_bound_->record(s, bk.key, m, a);
        key_at = std::max(ready, at);
      } else {
        const Time blb = lower();
        if (blb == kNever || loses(blb)) return;
        const Time ub = bound_time_->direct_upper_bound(s, bk.key, m, now);
        Time at = ub;
        if (!(ub <= blb * (1 + 1e-12))) {
          at = placer_->finder().arrival(bk.key, m);
          arrival_bound_->record(s, bk.key, m, at);
        } else {
          arrival_bound_->record(s, bk.key, m, bound_time_->lower_bound(s, bk.key, m, now));
        }
        key_at = std::max(ready, at);
      }
    }
  }
  if (key_at == kNever || loses(key_at)) return;
  const Time aging = aging_now_;
  const Sorted& so = sorted_jobs(i, d, m, pool, s);
  const bool in_order = so.monotone;  // else: every job, no early stop
  const std::size_t n = in_order ? so.jobs.size() : bk.jobs.size();
  const std::size_t k0 = in_order ? so.head : 0;  // (the planned jobs in front: skipped)
  auto job_at = [&](std::size_t k) { return in_order ? so.jobs[k].second : bk.jobs[k]; };
  // Can j run on d at all, its key block being fetchable? (Per bucket: whether the key
  // must be fetched and is a framebuffer, which only some job types may fetch.)
  const bool key_framebuffer_fetch = has_key && !key_copy && pool.block(bk.key).kind == DataKind::Framebuffer;
  const bool any_blocked = !blocked_pairs_.empty();
  auto eligible = [&](JobId j) {
    if (pool.state(j) != JobState::Queued) return false;
    if (deferred(j)) return false;
    const Job& job = pool.job(j);
    if (!g.timing.supports(d, job.type)) return false;
    if (!cells_.eligible(j, m)) return false;
    if (any_blocked && std::binary_search(blocked_pairs_.begin(), blocked_pairs_.end(), std::make_pair(j, m))) return false;
    return !(key_framebuffer_fetch && !Placer::may_fetch_framebuffer(job, s));
  };
  // select_pruned()'s per-job step: the exact start (searching only where the bounds
  // leave it open), folded into `best`. Returns the start (kNever: out).
  auto evaluate = [&](std::size_t k) -> Time {
    const JobId j = job_at(k);
    if (static_cast<std::size_t>(j) < floors_.size())
      if (const InputFloor& f = floors_[static_cast<std::size_t>(j)]; f.m == m && loses(f.lb) && s.holders_version(f.block) == f.holders)
        return kNever;
    if (!eligible(j)) return kNever;
    const Job& job = pool.job(j);
    Time start = std::max(key_at, s.after_deps_ready(j));
    for (BlockId b : job.inputs) {
      if (start == kNever || loses(start)) break;
      if (has_key && b == bk.key) continue;
      if (!Placer::may_fetch(job, b, s) && !s.copy_at(b, m)) {
        start = kNever;
        break;
      }
      Time lost_at = -kNever;
      start = fold_input(b, m, start, now, s, loses, lost_at);
      if (start == kNever && lost_at > -kNever) {
        if (static_cast<std::size_t>(j) >= floors_.size()) floors_.resize(std::max(2 * floors_.size(), static_cast<std::size_t>(j) + 1));
        InputFloor& f = floors_[static_cast<std::size_t>(j)];
        if (f.m == kNone) floor_jobs_.push_back(j);
        f = {lost_at, b, m, s.holders_version(b)};
      }
    }
    if (start == kNever || loses(start)) return kNever;
    Choice c;
    c.job = j;
    c.set_start(start);
    c.created = job.created;
    c.aged = aging != kNever && now - job.created >= aging;
    c.granularity = in_order ? so.jobs[k].first : granularity(j, d, pool, s);
    if (prefer_checked(c, best)) best = c;
    return start;
  };
  // Granularity order (else queue order). A job that starts at key_at, the earliest any
  // job here can, ends an in-order scan: later jobs have no smaller granularity (then a
  // larger id) and start no earlier. Jobs before it are folded with prefer_checked(), so
  // the order only decides how soon `loses` prunes, never the choice.
  for (std::size_t k = k0; k < n; ++k)
    if (evaluate(k) == key_at && in_order) break;
}

GmbScheduler::Choice GmbScheduler::select_indexed(DeviceId d, Time ready, Time now, const JobPool& pool,
                                                  const Schedule& s) {
  const MemId m = s.graph().computes[d].memory;
  MemIndex& mi = mem_index_[static_cast<std::size_t>(m)];
  if (!mi.built) {
    // With plan cells, the groups holding a bucket with jobs open on m (most buckets have
    // none homed in m's cell): the others would only be keyed and dropped.
    mi.built = true;
    mi.order.reset(arrival_bound_->group_count());
    if (cells_.flat()) {  // (every group, as a bucket scan would cost more than it saves)
      for (std::size_t g = 0; g < arrival_bound_->group_count(); ++g) mi.order.defer(static_cast<std::int32_t>(g));
    }
    group_seen_.assign(cells_.flat() ? 0 : arrival_bound_->group_count(), 0);
    for (std::size_t i = 0; !cells_.flat() && i < buckets_.size(); ++i) {
      if (static_cast<std::int32_t>(i) == no_key_bucket_ || open(static_cast<std::int32_t>(i), m) == 0) continue;
      const std::int32_t g = arrival_bound_->group(s, buckets_[i].key);
      if (g == kNone || group_seen_[static_cast<std::size_t>(g)]) continue;
      group_seen_[static_cast<std::size_t>(g)] = 1;
      mi.order.defer(g);
    }
  }
  Choice best;
  near_tie_ = false;
  if (no_key_bucket_ >= 0 && open(no_key_bucket_, m) > 0)
    evaluate_bucket(no_key_bucket_, d, m, ready, now, pool, s, best);
  // Groups re-entered since the last selection here get their keys (bucket_order.hpp).
  // (Stamps: the group's version, +1 so that 0 means none.)
  auto stamp_of = [&](std::int32_t g) { return arrival_bound_->version(g) + 1; };
  mi.order.settle([&](std::int32_t g) { return group_key(g, m, now, s); }, stamp_of);
  auto loses = [&](Time lb) { return best.loses(lb); };
  // In key order; a visited group keeps its place (its key is still a lower bound).
  for (std::size_t k = 0; k < mi.order.size();) {
    if (!mi.order.current(k)) {
      mi.order.erase(k);
      continue;
    }
    const BucketOrder::Entry e = mi.order.at(k);
    // A key computed since the group's version last changed is as high as group_key()
    // would make it (see ArrivalBound::version).
    const std::uint64_t stamp = stamp_of(e.bucket);
    const Time lb = e.stamp == stamp ? e.key : group_key(e.bucket, m, now, s);
    if (lb > e.key) {  // stale from below: raise it and look again
      mi.order.rekey(k, lb, stamp);
      continue;
    }
    if (loses(std::max(ready, e.key))) break;  // every group left starts later
    // A group with no queued job left is dropped (a block joining it re-inserts it).
    if (visit_group(e.bucket, d, m, ready, now, pool, s, best)) ++k;
    else mi.order.erase(k);
  }
  if (near_tie_) return select_pruned(d, ready, now, pool, s);
  return best;
}

void GmbScheduler::after_commit(std::size_t activities_before, std::size_t evictions_before, const JobPool& pool,
                                const Schedule& s) {
  // Blocks whose holders changed may have joined another holder group, which may now
  // start earlier anywhere: that group re-enters every memory device's order.
  auto changed = [&](BlockId b) {
    if (static_cast<std::size_t>(b) >= bucket_of_block_.size() || bucket_of_block_[b] < 0) return;
    if (arrival_bound_->group(s, b) != kNone) return;  // holders as before (or seen already)
    const std::int32_t g = arrival_bound_->assign(s, b);
    // b's bucket now belongs to g, which may start earlier: g re-enters the order of every
    // memory device where b's bucket has open jobs. Elsewhere g's key still bounds the
    // members that matter there (open counts only fall within a plan).
    const std::int32_t i = bucket_of_block_[b];
    for (std::size_t m = 0; m < mem_index_.size(); ++m)
      if (mem_index_[m].built && open(i, static_cast<MemId>(m)) > 0) mem_index_[m].order.defer(g);
  };
  for (std::size_t a = activities_before; a < s.activity_count(); ++a) {
    const Activity& act = s.activity(static_cast<ActivityId>(a));
    if (act.kind == ActivityKind::Transfer) {
      changed(act.block);
    } else {
      if (static_cast<std::size_t>(act.job) < bucket_of_job_.size() && bucket_of_job_[act.job] >= 0) {
        const std::int32_t i = bucket_of_job_[act.job];
        --buckets_[static_cast<std::size_t>(i)].queued;
        std::int32_t* open_i = open_.data() + static_cast<std::size_t>(i) * mem_index_.size();
        auto close = [&](std::size_t m) {
          if (blocked_pairs_.empty() || !std::binary_search(blocked_pairs_.begin(), blocked_pairs_.end(), std::make_pair(act.job, static_cast<MemId>(m))))
            --open_i[m];
        };
        if (const std::int32_t h = cells_.home(act.job); !cells_.flat() && h != kNone) {
          for (MemId m : cells_.memories(h)) close(static_cast<std::size_t>(m));
        } else {
          for (std::size_t m = 0; m < mem_index_.size(); ++m) close(m);
        }
      }
      for (BlockId b : pool.job(act.job).inputs) changed(b);
      for (BlockId o : pool.job(act.job).outputs) changed(o);
    }
  }
  for (std::size_t e = evictions_before; e < s.evictions().size(); ++e) changed(s.evictions()[e].block);
}

// completion_aware: would another device finish this job earlier than d, given when it
// is free and when the inputs could reach it?
bool GmbScheduler::better_elsewhere(const Choice& c, DeviceId d, const JobPool& pool, const Schedule& s) {
  if (c.aged) return false;
  const Time finish_here = c.start + Placer::exec_estimate(c.job, d, s);
  const DeviceGraph& g = s.graph();
  const Job& job = pool.job(c.job);
  for (std::size_t o = 0; o < g.computes.size(); ++o) {
    const auto od = static_cast<DeviceId>(o);
    if (od == d || !g.timing.supports(od, job.type) || !s.compute_alive(od)) continue;
    if (!cells_.eligible(c.job, g.computes[od].memory)) continue;
    const Time ready_o = std::max(now_, s.device_timeline(od).busy_until);
    const Time exec_o = Placer::exec_estimate(c.job, od, s);
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
  if (static_cast<std::size_t>(c.job) < bucket_of_job_.size() && bucket_of_job_[c.job] >= 0 && !open_.empty())
    --open_[static_cast<std::size_t>(bucket_of_job_[c.job]) * mem_index_.size() + static_cast<std::size_t>(key.second)];
  return false;
}

PlanStats GmbScheduler::plan(Time now, JobPool& pool, Schedule& s) {
  const auto t0 = std::chrono::steady_clock::now();
  PlanStats st;
  // (A large graph is fingerprinted once per graph object and size: hashing a million LAN
  // channels at every plan would cost more than the plan. Small graphs, which the renderer
  // may rebuild in place between frames, are hashed every time.)
  const DeviceGraph& sg = s.graph();
  const std::array<std::size_t, 4> shape{reinterpret_cast<std::uintptr_t>(&sg), sg.channels.size(), sg.memories.size(),
                                         sg.computes.size()};
  if (sg.channels.size() <= 4096 || shape != graph_shape_) {
    graph_shape_ = shape;
    graph_shape_print_ = fingerprint(sg);
  }
  const std::uint64_t print = graph_shape_print_;
  if (!placer_ || print != graph_print_) {
    placer_ = std::make_unique<Placer>(s);
    bound_time_ = std::make_unique<FetchBound>(s.graph());
    arrival_bound_ = std::make_unique<ArrivalBound>(s.graph());
    cells_.build(s.graph(), opt_.cell_nodes);
  } else if (bound_ != &s) {
    placer_->rebind(s);  // same platform: keep the buffers (every cache is reset below)
  }
  bound_ = &s;
  graph_print_ = print;
  s.reproject(now);
  const DeviceGraph& g = s.graph();
  placer_->finder().clear();
  placer_->finder().set_now(now);
  placer_->finder().set_bounds(bound_time_.get());
  blocked_pairs_.clear();
  for (JobId j : floor_jobs_) floors_[static_cast<std::size_t>(j)] = InputFloor{};
  floor_jobs_.clear();
  cells_.assign(now, opt_.horizon, pool, s);
  build_index(now, pool);
  bound_time_->reset();
  mem_index_.resize(g.memories.size());
  for (MemIndex& mi : mem_index_) mi.built = false;
  arrival_bound_->reset(now);
  open_.assign(buckets_.size() * g.memories.size(), 0);
  if (cells_.flat()) {
    for (std::size_t i = 0; i < buckets_.size(); ++i)
      std::fill_n(open_.begin() + static_cast<std::ptrdiff_t>(i * g.memories.size()), g.memories.size(), buckets_[i].queued);
  } else {  // per memory device: the bucket's jobs homed in its cell or in none
    const auto cells = static_cast<std::size_t>(cells_.count());
    std::vector<std::int32_t> homed(cells + 1);
    for (std::size_t i = 0; i < buckets_.size(); ++i) {
      std::fill(homed.begin(), homed.end(), 0);
      for (JobId j : buckets_[i].jobs) {
        const std::int32_t h = cells_.home(j);
        ++homed[h == kNone ? cells : static_cast<std::size_t>(h)];
      }
      std::int32_t* open_i = open_.data() + i * g.memories.size();
      for (std::size_t m = 0; m < g.memories.size(); ++m)
        open_i[m] = homed[static_cast<std::size_t>(cells_.cell_of_memory(static_cast<MemId>(m)))] + homed[cells];
    }
  }
  no_key_bucket_ = -1;
  keys_.clear();
  for (std::size_t i = 0; i < buckets_.size(); ++i) {
    if (static_cast<std::size_t>(buckets_[i].key) < pool.block_count()) keys_.push_back(buckets_[i].key);
    else no_key_bucket_ = static_cast<std::int32_t>(i);
  }
  arrival_bound_->assign_all(s, keys_);
  build_classes(s);
  const std::size_t n_sorted = buckets_.size() * static_cast<std::size_t>(cells_.count()) * static_cast<std::size_t>(classes_);
  if (sorted_.size() < n_sorted) sorted_.resize(n_sorted);
  for (std::size_t k = 0; k < n_sorted; ++k) {
    sorted_[k].built = false;
    sorted_[k].monotone = true;
    sorted_[k].head = 0;
    sorted_[k].jobs.clear();
  }
  const std::uint64_t searches0 = placer_->finder().searches(), hits0 = placer_->finder().hits();
  const std::uint64_t cut0 = placer_->finder().cut_searches();
  now_ = now;
  const Time end = now + opt_.horizon;
  // Sec. 4.2 device selection: the device whose timeline ends first (a min-heap on the
  // ready time, then the device id, as std::priority_queue with std::greater<> would).
  auto& devices = device_queue_;
  devices.clear();
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    if (!s.compute_alive(static_cast<DeviceId>(d))) continue;  // lost (Schedule::fail)
    devices.emplace_back(std::max(now, s.device_timeline(static_cast<DeviceId>(d)).busy_until), static_cast<DeviceId>(d));
    std::push_heap(devices.begin(), devices.end(), std::greater<>{});
  }
  while (!devices.empty() && pool.queued_count() > 0) {
    std::pop_heap(devices.begin(), devices.end(), std::greater<>{});
    const auto [ready, d] = devices.back();
    devices.pop_back();
    // Every device is planned up to now + k. A device that is dry now is planned whatever
    // k is: Sec. 4.2 re-plans when a device runs dry, and a k below the resolution of
    // `now` (now + k == now) must not leave it idle, or the run would stall.
    if (ready >= end && ready > now) break;
    deferred_.clear();
    for (;;) {
      const Choice c = select(d, ready, now, pool, s);
      if (c.job == kNone) break;  // nothing this device can run: it leaves this round
      // At most 16 deferrals per placement keep the refinement's cost bounded.
      if (opt_.completion_aware && c.start > ready && deferred_.size() < 16 && better_elsewhere(c, d, pool, s)) {
        deferred_.push_back(c.job);
        continue;
      }
      const std::size_t activities_before = s.activity_count(), evictions_before = s.evictions().size();
      const bool placed = commit(c, d, ready, now, pool, s, st);
      after_commit(activities_before, evictions_before, pool, s);
      if (placed) {
        devices.emplace_back(std::max(now, s.device_timeline(d).busy_until), d);
        std::push_heap(devices.begin(), devices.end(), std::greater<>{});
        break;
      }
    }
  }
  search_stats_.path_searches = placer_->finder().searches() - searches0;
  search_stats_.path_cache_hits = placer_->finder().hits() - hits0;
  search_stats_.path_cut_searches = placer_->finder().cut_searches() - cut0;
  st.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace rayline

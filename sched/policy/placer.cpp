#include "sched/policy/placer.hpp"

#include <algorithm>

namespace rayline {

bool Placer::may_fetch_framebuffer(const Job& j, const Schedule& s) {
  return s.graph().job_types[static_cast<std::size_t>(j.type)] == "AdditiveCompose";
}

Time Placer::exec_estimate(JobId j, DeviceId d, const Schedule& s) {
  const JobPool& pool = s.pool();
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

Time Placer::earliest_start(JobId j, DeviceId d, Time ready, const Schedule& s) {
  const MemId m = s.graph().computes[d].memory;
  Time arrive = s.after_deps_ready(j);
  if (arrive == kNever) return kNever;
  const Job& job = s.pool().job(j);
  arrive = std::max(ready, arrive);
  const auto never_lost = [](Time) { return false; };
  // A job that merged many ray queues (Sec. 5.1) reads hundreds of blocks, each with one
  // copy, on a few memory devices. For movable blocks of one kind (not scene data, whose
  // paths may be restricted) from one memory device the SDC search differs only in the
  // bytes moved and the time the copy is ready, and its arrival does not decrease with
  // either: each hop's slot and Eq. 1 time grow with the bytes, a memory device too small
  // for a block only removes paths, and nothing starts before the copy is ready. So only
  // the blocks that no other one matches in both (the Pareto front of ready time and
  // size) can arrive last, and only they are searched.
  constexpr std::size_t kFewInputs = 4;
  const bool front = job.inputs.size() > kFewInputs;
  one_copy_.clear();
  for (BlockId b : job.inputs) {
    const Copy* c = s.copy_at(b, m);
    if (!c && !may_fetch(job, b, s)) return kNever;
    if (c) {
      arrive = std::max(arrive, s.copy_ready(*c));
      continue;
    }
    const DataBlock& blk = s.pool().block(b);
    if (front && blk.movable && blk.kind != DataKind::SceneData && s.copies(b).size() == 1) {
      const Copy& from = s.copies(b).front();
      one_copy_.push_back({from.mem, blk.kind, s.copy_ready(from), blk.bytes, b});
      continue;
    }
    // Only max(arrive, SDC arrival) matters: arrival_within answers "by then" without a
    // full search when it can, and the exact arrival (arrival()'s value) otherwise.
    arrive = std::max(arrive, finder_.arrival_within(b, m, arrive, never_lost));
    if (arrive == kNever) return kNever;
  }
  // Per (memory device, kind), the front: the block ready latest (the larger among equals),
  // then the one ready latest among those larger than it, and so on. Each is found by a
  // scan of the group (fronts are short), not by sorting the inputs; the order of the
  // searches does not change the maximum. Two blocks alike in group, ready time and size
  // arrive at the same time, so one of them is searched.
  groups_.clear();
  for (const OneCopyInput& in : one_copy_)
    if (std::find(groups_.begin(), groups_.end(), std::pair{in.from, in.kind}) == groups_.end())
      groups_.emplace_back(in.from, in.kind);
  constexpr int kScans = 16;  // a longer front: the rest of the group is sorted once
  for (const auto& [from, kind] : groups_) {
    rest_.clear();
    for (const OneCopyInput& in : one_copy_)
      if (in.from == from && in.kind == kind) rest_.push_back(in);
    // rest_: the group's blocks larger than every one searched so far.
    for (int scans = 0; arrive != kNever && !rest_.empty(); ++scans) {
      if (scans == kScans) {
        std::sort(rest_.begin(), rest_.end(), [](const OneCopyInput& x, const OneCopyInput& y) {
          return x.ready != y.ready ? x.ready > y.ready : x.bytes > y.bytes;
        });
        Bytes larger_than = 0;
        for (const OneCopyInput& in : rest_) {
          if (arrive == kNever) break;
          if (in.bytes <= larger_than) continue;  // a block ready no earlier is no smaller
          larger_than = in.bytes;
          arrive = std::max(arrive, finder_.arrival_within(in.block, m, arrive, never_lost));
        }
        break;
      }
      const OneCopyInput* best = &rest_.front();
      for (const OneCopyInput& in : rest_)
        if (in.ready > best->ready || (in.ready == best->ready && in.bytes > best->bytes)) best = &in;
      const OneCopyInput pick = *best;
      arrive = std::max(arrive, finder_.arrival_within(pick.block, m, arrive, never_lost));
      std::erase_if(rest_, [&](const OneCopyInput& in) { return in.bytes <= pick.bytes; });
    }
  }
  return arrive;
}

bool Placer::place(JobId j, DeviceId d, Time ready, Time now, JobPool& pool, Schedule& s, PlanStats& st) {
  const DeviceGraph& g = s.graph();
  const MemId m = g.computes[d].memory;
  const Job& job = pool.job(j);
  const std::vector<BlockId>& keep = job.inputs;
  finder_.set_now(now);
  // Feasibility first, so a job that cannot fit leaves no half-built chain behind.
  Bytes need_here = 0;
  paths_.clear();
  path_end_.clear();
  for (BlockId b : job.inputs) {
    if (s.copy_at(b, m)) continue;
    if (!may_fetch(job, b, s)) return false;
    need_here += pool.block(b).bytes;
    finder_.path(b, m, path_);
    if (path_.empty()) return false;
    paths_.insert(paths_.end(), path_.begin(), path_.end());
    path_end_.push_back(paths_.size());
    for (std::size_t h = 0; h + 1 < path_.size(); ++h)
      if (s.admission(g.channels[path_[h]].to, pool.block(b).bytes, keep).at == kNever) return false;
  }
  for (BlockId o : job.outputs) need_here += pool.block(o).bytes;
  if (s.admission(m, need_here, keep).at == kNever) return false;

  // Sec. 4.4: chained T-jobs along each SDC path, then the E-job.
  const std::size_t evictions_before = s.evictions().size();
  const std::size_t activities_before = s.activity_count();
  std::size_t fetched = 0;
  for (BlockId b : job.inputs) {
    if (s.copy_at(b, m)) continue;
    // Until something is committed the schedule is as the feasibility pass saw it, and
    // path() would answer the same.
    if (s.activity_count() == activities_before && fetched < path_end_.size()) {
      path_.assign(paths_.begin() + static_cast<std::ptrdiff_t>(fetched ? path_end_[fetched - 1] : 0),
                   paths_.begin() + static_cast<std::ptrdiff_t>(path_end_[fetched]));
    } else {
      finder_.path(b, m, path_);
    }
    ++fetched;
    for (ChannelId ch : path_) {
      const auto adm = s.admission(g.channels[ch].to, pool.block(b).bytes, keep);
      // Rare: an earlier hop of another input took the room. What was placed stays as a
      // prefetch (the data is moved closer); the job is retried later.
      if (adm.at == kNever) return false;
      s.commit_transfer(b, ch, j, now, adm);
      ++st.transfers;
    }
  }
  Bytes out_bytes = 0;
  for (BlockId o : job.outputs) out_bytes += pool.block(o).bytes;
  const auto out_adm = s.admission(m, out_bytes, keep);
  if (out_adm.at == kNever) return false;
  const ActivityId e = s.commit_exec(j, d, ready, out_adm);
  pool.mark_planned(j, e);
  ++st.execs;
  st.evictions += static_cast<int>(s.evictions().size() - evictions_before);
  return true;
}

}  // namespace rayline

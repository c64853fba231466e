// Schedule::fail (docs/faults.md): devices lost mid-run, or activities that failed on their
// own. The plan is append-only (Sec. 4.1), so nothing is erased: the lost activities are
// marked Failed and withdrawn, the copies they were to make disappear, the copies they
// were to consume or move away are put back, and the memory reservations are recomputed
// from what is left. The runtime loop then queues the aborted jobs again and re-plans
// (Sec. 4.2: a device whose timeline runs dry triggers a plan).
#include <algorithm>

#include "sched/timeline/schedule.hpp"

namespace rayline {

Schedule::Failure Schedule::fail(Time now, const std::vector<ActivityId>& seeds, const std::vector<DeviceId>& computes,
                                 const std::vector<MemId>& memories) {
  ++ends_epoch_;  // (leaving_order)
  Failure f;
  const DeviceGraph& g = *graph_;
  if (dead_compute_.empty()) {
    dead_compute_.assign(g.computes.size(), 0);
    dead_memory_.assign(g.memories.size(), 0);
    dead_channel_.assign(g.channels.size(), 0);
  }
  for (MemId m : memories) {
    dead_memory_[static_cast<std::size_t>(m)] = 1;
    for (DeviceId d : g.computes_on(m)) dead_compute_[static_cast<std::size_t>(d)] = 1;
  }
  for (DeviceId d : computes) dead_compute_[static_cast<std::size_t>(d)] = 1;
  for (std::size_t c = 0; c < g.channels.size(); ++c)
    if (!memory_alive(g.channels[c].from) || !memory_alive(g.channels[c].to)) dead_channel_[c] = 1;

  // What is aborted: in id order (every dependency has a smaller id), so one pass reaches
  // everything that waits, directly or not, for a seed or for an activity on a lost device.
  std::vector<char> aborted(acts_.size(), 0);
  for (ActivityId s : seeds)
    if (acts_[s].state != ActivityState::Done && acts_[s].state != ActivityState::Failed) aborted[s] = 1;
  for (ActivityId id : pending_) {
    const Activity& a = acts_[id];
    if (a.state == ActivityState::Done || a.state == ActivityState::Failed) continue;
    bool x = aborted[id] || (a.kind == ActivityKind::Exec ? !compute_alive(a.device) : !channel_alive(a.channel));
    for (std::size_t k = 0; !x && k < a.deps.size(); ++k) x = aborted[a.deps[k]];
    if (!x) continue;
    aborted[id] = 1;
    f.aborted.push_back(id);
  }
  auto is_aborted = [&](ActivityId a) { return a != kNone && static_cast<std::size_t>(a) < aborted.size() && aborted[a]; };

  for (ActivityId id : f.aborted) {
    Activity& a = acts_[id];
    if (a.kind == ActivityKind::Exec) {
      --device_pending_[a.device];
      if (!a.cancelled) f.jobs.push_back(a.job);
    }
    --unfinished_;
    a.placeholder = a.state == ActivityState::Planned;
    a.state = ActivityState::Failed;
    touch(a);
    a.cancelled = true;  // (read_after_eviction and the metrics skip it)
    a.duration = a.setup = 0;
    if (a.placeholder) {
      a.deps.erase_if([](ActivityId) { return true; });  // (reproject() places it after its timeline predecessors)
    } else {
      a.start = std::min(a.start, now);  // stopped while it ran
      a.end = now;
    }
  }

  // Copies: the ones an aborted activity was to make go; so do the ones on lost memories.
  // A block that had data on a lost memory and no copy left anywhere is lost.
  std::vector<BlockId> touched;
  std::vector<char> physical_loss(copies_.size(), 0);
  for (std::size_t b = 0; b < copies_.size(); ++b) {
    auto& v = copies_[b];
    if (v.empty()) continue;
    const std::size_t before = v.size();
    std::erase_if(v, [&](const Copy& c) {
      if (!memory_alive(c.mem)) {
        if (c.producer == kNone || acts_[c.producer].state == ActivityState::Done) physical_loss[b] = 1;
        return true;
      }
      return is_aborted(c.producer);
    });
    for (Copy& c : v) c.users.erase_if(is_aborted);
    if (v.size() != before) {
      touched.push_back(static_cast<BlockId>(b));
      ++holders_version_[b];  // (copy_at() below must not answer from the old positions)
    }
  }
  // Leaving entries: a copy an aborted activity was to consume or move away is still there
  // (back in the plan, as present, or as arriving from its producer); other entries stop
  // waiting for aborted activities, and those left waiting for nothing are free.
  for (std::vector<Leaving>& lv : leaving_) {
    std::vector<Leaving> kept;
    kept.reserve(lv.size());
    for (Leaving& l : lv) {
      if (l.after.empty()) continue;  // dead: its room was freed already
      if (is_aborted(l.dropped_by)) {
        const BlockId b = l.block;
        if (!memory_alive(l.mem)) {
          if (l.producer == kNone || acts_[l.producer].state == ActivityState::Done) physical_loss[b] = 1;
          continue;
        }
        if (is_aborted(l.producer) || copy_at(b, l.mem)) continue;
        Copy c;
        c.mem = l.mem;
        if (l.producer != kNone && acts_[l.producer].state == ActivityState::Done) {
          c.initial_ready = acts_[l.producer].end;
        } else {
          c.producer = l.producer;
          c.initial_ready = l.ready;
        }
        note_cached(b, c.mem);
        copies_[b].push_back(std::move(c));
        ++holders_version_[b];
        touched.push_back(b);
        continue;
      }
      l.after.erase_if(is_aborted);
      if (!l.after.empty()) kept.push_back(std::move(l));
    }
    lv = std::move(kept);
  }
  std::fill(dead_leaving_.begin(), dead_leaving_.end(), std::size_t{0});

  // Reservations recomputed from what is left: every copy and every leaving entry.
  std::fill(used_.begin(), used_.end(), Bytes{0});
  for (std::size_t b = 0; b < copies_.size(); ++b)
    for (const Copy& c : copies_[b]) used_[c.mem] += pool_->block(static_cast<BlockId>(b)).bytes;
  for (const std::vector<Leaving>& lv : leaving_)
    for (const Leaving& l : lv) used_[l.mem] += l.bytes;
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  for (BlockId b : touched) {
    ++holders_version_[b];
    std::uint64_t mask = 0;
    for (const Copy& c : copies_[b])
      if (static_cast<std::uint32_t>(c.mem) < 64u) mask |= std::uint64_t{1} << c.mem;
    holder_mask_[b] = mask;
    if (copies_[b].empty() && physical_loss[b]) f.lost.push_back(b);
  }
  for (std::size_t b = 0; b < physical_loss.size(); ++b)
    if (physical_loss[b] && copies_[b].empty() && !std::binary_search(touched.begin(), touched.end(), static_cast<BlockId>(b)))
      f.lost.push_back(static_cast<BlockId>(b));
  for (auto& v : resource_version_) ++v;
  reproject(now);
  return f;
}

}  // namespace rayline

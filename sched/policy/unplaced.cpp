#include "sched/policy/unplaced.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <unordered_map>
#include <vector>

#include "sched/core/job_pool.hpp"
#include "sched/policy/placer.hpp"
#include "sched/timeline/schedule.hpp"

namespace rayline {

namespace {

std::string gb(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g GB", bytes / 1e9);
  return buf;
}

// Memory devices a copy of a block of `bytes` can reach hop by hop from `holders`, each
// hop's memory device big enough to hold it (Placer::place admits the block on every hop,
// Sec. 4.4).
std::vector<bool> reachable(const std::vector<MemId>& holders, double bytes, const Schedule& s) {
  const DeviceGraph& g = s.graph();
  std::vector<bool> seen(g.memories.size(), false);
  std::vector<MemId> todo;
  for (MemId m : holders) {
    seen[static_cast<std::size_t>(m)] = true;
    todo.push_back(m);
  }
  while (!todo.empty()) {
    const MemId u = todo.back();
    todo.pop_back();
    for (const ChannelId ci : g.out_channels(u)) {
      const auto v = static_cast<std::size_t>(g.channels[static_cast<std::size_t>(ci)].to);
      if (!s.channel_alive(ci) || seen[v] || static_cast<double>(g.memories[v].capacity) < bytes) continue;
      seen[v] = true;
      todo.push_back(static_cast<MemId>(v));
    }
  }
  return seen;
}

// Where blocks can get to. first_unplaceable asks for every queued job; many share their
// inputs (the scene blocks), and many more share where their input is and which memory
// devices are big enough for it (every ray queue held by one RAM): the answer depends only
// on the holders and on how many of the platform's distinct capacities are too small, so
// it is kept per (holders, capacity class), found per block once.
class ReachCache {
 public:
  explicit ReachCache(const Schedule& s) : s_(s) {
    for (const MemoryDevice& m : s.graph().memories) capacities_.push_back(static_cast<double>(m.capacity));
    std::sort(capacities_.begin(), capacities_.end());
    capacities_.erase(std::unique(capacities_.begin(), capacities_.end()), capacities_.end());
  }
  const std::vector<bool>& of(BlockId b) {
    auto [it, fresh] = by_block_.try_emplace(b, nullptr);
    if (!fresh) return *it->second;
    const double bytes = static_cast<double>(s_.pool().block(b).bytes);
    Key key;
    for (const Copy& c : s_.copies(b)) key.first.push_back(c.mem);
    std::sort(key.first.begin(), key.first.end());
    key.second = std::lower_bound(capacities_.begin(), capacities_.end(), bytes) - capacities_.begin();
    auto [r, new_key] = by_key_.try_emplace(std::move(key));
    if (new_key) r->second = reachable(r->first.first, bytes, s_);
    it->second = &r->second;
    return r->second;
  }

 private:
  using Key = std::pair<std::vector<MemId>, std::ptrdiff_t>;
  const Schedule& s_;
  std::vector<double> capacities_;  // distinct, ascending
  std::map<Key, std::vector<bool>> by_key_;
  std::unordered_map<BlockId, const std::vector<bool>*> by_block_;
};

std::string why_unplaceable(JobId j, const JobPool& pool, const Schedule& s, ReachCache& cache) {
  const DeviceGraph& g = s.graph();
  const Job& job = pool.job(j);
  const std::string& type = g.job_types[static_cast<std::size_t>(job.type)];
  double need = 0;
  for (BlockId b : job.inputs) need += static_cast<double>(pool.block(b).bytes);
  for (BlockId o : job.outputs) need += static_cast<double>(pool.block(o).bytes);
  // Where each input can get to, worked out at its first need (most devices hold the
  // inputs already). An input no memory device holds yet is the output of a job still to
  // run (a DAG): it is no obstacle, left empty.
  std::vector<std::vector<bool>> reach(job.inputs.size());
  std::vector<bool> reach_known(job.inputs.size(), false);
  auto reach_of = [&](std::size_t i) -> const std::vector<bool>& {
    if (reach_known[i]) return reach[i];
    reach_known[i] = true;
    reach[i] = cache.of(job.inputs[i]);
    if (std::find(reach[i].begin(), reach[i].end(), true) == reach[i].end()) reach[i].clear();
    return reach[i];
  };
  // Reasons by preference: the one of a device whose memory is big enough says more.
  std::string too_small, blocked;
  double largest = -1;
  bool any_device = false;
  std::vector<char> memory_checked(g.memories.size(), 0);  // devices on one memory device share the answer
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    if (!g.timing.supports(static_cast<DeviceId>(d), job.type) || !s.compute_alive(static_cast<DeviceId>(d))) continue;
    any_device = true;
    const MemId m = g.computes[d].memory;
    if (memory_checked[static_cast<std::size_t>(m)]) continue;
    memory_checked[static_cast<std::size_t>(m)] = 1;
    const MemoryDevice& mem = g.memories[static_cast<std::size_t>(m)];
    if (need > static_cast<double>(mem.capacity)) {
      if (static_cast<double>(mem.capacity) > largest) {
        largest = static_cast<double>(mem.capacity);
        too_small = "its inputs and outputs need " + gb(need) + " in one memory device, and the largest that a device "
                    "running " + type + " works from (" + mem.name + ") holds " + gb(largest);
      }
      continue;
    }
    std::string reason;
    for (std::size_t i = 0; i < job.inputs.size(); ++i) {
      const BlockId b = job.inputs[i];
      if (s.copy_at(b, m)) continue;
      const std::string& bn = pool.block(b).name;
      if (!Placer::may_fetch(job, b, s)) {
        reason = "input '" + bn + "' may not move (a framebuffer moves only for AdditiveCompose, Sec. 5.1) and is not on " + mem.name;
        break;
      }
      if (const std::vector<bool>& r = reach_of(i); !r.empty() && !r[static_cast<std::size_t>(m)]) {
        reason = "no chain of channels, each hop with room for input '" + bn + "' (" +
                 gb(static_cast<double>(pool.block(b).bytes)) + "), leads from its holders to " + mem.name;
        break;
      }
    }
    if (reason.empty()) return "";  // d could take it: the obstacle is what else is planned
    if (blocked.empty()) blocked = "on " + g.computes[d].name + ": " + reason;
  }
  if (!any_device)
    return std::string(s.any_lost() ? "no compute device left (the others were lost)" : "no compute device of the platform") +
           " runs job type " + type;
  return blocked.empty() ? too_small : blocked;
}

}  // namespace

std::string why_unplaceable(JobId j, const JobPool& pool, const Schedule& s) {
  ReachCache cache(s);
  return why_unplaceable(j, pool, s, cache);
}

JobId first_unplaceable(const JobPool& pool, const Schedule& s) {
  ReachCache cache(s);
  for (JobId j : pool.queued())
    if (!why_unplaceable(j, pool, s, cache).empty()) return j;
  return kNone;
}

std::string unplaced_summary(const JobPool& pool, const Schedule& s) {
  std::string msg = std::to_string(pool.queued_count()) + " job(s) could not be placed on any device";
  if (pool.queued_count() == 0) return msg;
  const JobId first = first_unplaceable(pool, s);
  const JobId j = first != kNone ? first : *pool.queued().begin();
  const std::string why = first != kNone ? why_unplaceable(j, pool, s) : std::string();
  return msg + "; job '" + pool.job(j).name + "': " +
         (why.empty() ? "no device had room for its inputs next to the blocks that planned jobs keep" : why);
}

}  // namespace rayline

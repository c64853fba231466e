#include "sched/policy/unplaced.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>
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

// Memory devices a copy of a block can reach hop by hop from its holders, each hop's
// memory device big enough to hold it (Placer::place admits the block on every hop,
// Sec. 4.4). Per size class (the devices big enough): the strongly connected components
// of the live channels between those devices (Tarjan), and each component's reach
// through the condensation, so a block's answer is a union of a few precomputed sets, not
// a walk over every channel (a network of N members has N² of them).
class ClassReach {
 public:
  ClassReach(const Schedule& s, Bytes min_capacity) : s_(s), comp_(s.graph().memories.size(), -1) {
    const DeviceGraph& g = s.graph();
    const std::size_t n = g.memories.size();
    in_.assign(n, 0);
    for (std::size_t m = 0; m < n; ++m) in_[m] = g.memories[m].capacity >= min_capacity;
    // Tarjan, iterative: components come out sinks first, so each one's successors are done.
    std::vector<std::int32_t> index(n, -1), low(n, 0);
    std::vector<char> on_stack(n, 0);
    std::vector<MemId> stack;
    std::vector<std::pair<MemId, std::size_t>> call;  // (device, next out-channel)
    std::int32_t next = 0;
    for (std::size_t root = 0; root < n; ++root) {
      if (!in_[root] || index[root] >= 0) continue;
      call.emplace_back(static_cast<MemId>(root), 0);
      while (!call.empty()) {
        auto& [u, k] = call.back();
        const auto ui = static_cast<std::size_t>(u);
        if (k == 0 && index[ui] < 0) {
          index[ui] = low[ui] = next++;
          stack.push_back(u);
          on_stack[ui] = 1;
        }
        const auto& out = g.out_channels(u);
        if (k < out.size()) {
          const ChannelId c = out[k++];
          const auto v = static_cast<std::size_t>(g.channels[static_cast<std::size_t>(c)].to);
          if (!in_[v] || !s.channel_alive(c)) continue;
          if (index[v] < 0) {
            call.emplace_back(static_cast<MemId>(v), 0);
          } else if (on_stack[v]) {
            low[ui] = std::min(low[ui], index[v]);
          }
          continue;
        }
        if (low[ui] == index[ui]) {  // u roots a component: pop it, then its reach
          const auto id = static_cast<std::int32_t>(reach_.size());
          std::vector<MemId> members;
          MemId w;
          do {
            w = stack.back();
            stack.pop_back();
            on_stack[static_cast<std::size_t>(w)] = 0;
            comp_[static_cast<std::size_t>(w)] = id;
            members.push_back(w);
          } while (w != u);
          std::vector<bool> r(n, false);
          for (MemId x : members) {
            r[static_cast<std::size_t>(x)] = true;
            for (ChannelId c : g.out_channels(x)) {
              const auto v = static_cast<std::size_t>(g.channels[static_cast<std::size_t>(c)].to);
              if (!in_[v] || !s.channel_alive(c) || comp_[v] == id || comp_[v] < 0) continue;
              const std::vector<bool>& rv = reach_[static_cast<std::size_t>(comp_[v])];
              for (std::size_t y = 0; y < n; ++y) r[y] = r[y] || rv[y];
            }
          }
          reach_.push_back(std::move(r));
        }
        const MemId done = u;
        call.pop_back();
        if (!call.empty()) {
          const auto pi = static_cast<std::size_t>(call.back().first);
          low[pi] = std::min(low[pi], low[static_cast<std::size_t>(done)]);
        }
      }
    }
  }
  // Where a block held by `holders` can get to (the holders themselves included).
  std::vector<bool> from(const std::vector<MemId>& holders) const {
    const DeviceGraph& g = s_.graph();
    std::vector<bool> seen(g.memories.size(), false);
    auto add = [&](std::int32_t comp) {
      const std::vector<bool>& r = reach_[static_cast<std::size_t>(comp)];
      for (std::size_t y = 0; y < seen.size(); ++y) seen[y] = seen[y] || r[y];
    };
    std::vector<char> added(reach_.size(), 0);
    for (MemId h : holders) {
      const auto hi = static_cast<std::size_t>(h);
      seen[hi] = true;
      if (comp_[hi] >= 0) {
        if (!added[static_cast<std::size_t>(comp_[hi])]++) add(comp_[hi]);
        continue;
      }
      for (ChannelId c : g.out_channels(h)) {  // a holder too small to be a hop itself
        const auto v = static_cast<std::size_t>(g.channels[static_cast<std::size_t>(c)].to);
        if (in_[v] && s_.channel_alive(c) && !added[static_cast<std::size_t>(comp_[v])]++) add(comp_[v]);
      }
    }
    return seen;
  }

 private:
  const Schedule& s_;
  std::vector<char> in_;
  std::vector<std::int32_t> comp_;          // per memory device (-1: too small)
  std::vector<std::vector<bool>> reach_;    // per component
};

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
    if (new_key) {
      const auto cls = static_cast<std::size_t>(r->first.second);
      auto [c, new_class] = classes_.try_emplace(cls);
      if (new_class) c->second = std::make_unique<ClassReach>(s_, static_cast<Bytes>(cls < capacities_.size() ? capacities_[cls] : bytes));
      r->second = c->second->from(r->first.first);
    }
    it->second = &r->second;
    return r->second;
  }

 private:
  using Key = std::pair<std::vector<MemId>, std::ptrdiff_t>;
  const Schedule& s_;
  std::vector<double> capacities_;  // distinct, ascending
  std::map<Key, std::vector<bool>> by_key_;
  std::unordered_map<BlockId, const std::vector<bool>*> by_block_;
  std::unordered_map<std::size_t, std::unique_ptr<ClassReach>> classes_;  // per size class
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
  // Whether every input of the job is on memory device m or can get there (its room is
  // the caller's check); `reason`: why not.
  auto takes = [&](MemId m, std::string* reason) {
    const MemoryDevice& mem = g.memories[static_cast<std::size_t>(m)];
    for (std::size_t i = 0; i < job.inputs.size(); ++i) {
      const BlockId b = job.inputs[i];
      if (s.copy_at(b, m)) continue;
      const std::string& bn = pool.block(b).name;
      if (!Placer::may_fetch(job, b, s)) {
        if (reason) *reason = "input '" + bn + "' may not move (a framebuffer moves only for AdditiveCompose, Sec. 5.1) and is not on " + mem.name;
        return false;
      }
      if (const std::vector<bool>& r = reach_of(i); !r.empty() && !r[static_cast<std::size_t>(m)]) {
        if (reason)
          *reason = "no chain of channels, each hop with room for input '" + bn + "' (" +
                    gb(static_cast<double>(pool.block(b).bytes)) + "), leads from its holders to " + mem.name;
        return false;
      }
    }
    return true;
  };
  // Most queued jobs can run where their last input is (a merged job holds thousands of
  // ray queues there): asked first, so the walk below, which may read every input on
  // every memory device before it, is left to the jobs that might not run at all.
  if (!job.inputs.empty())
    if (const std::vector<Copy>& cs = s.copies(job.inputs.back()); !cs.empty()) {
      const MemId m = cs.front().mem;
      for (DeviceId d : g.computes_on(m))
        if (g.timing.supports(d, job.type) && s.compute_alive(d)) {
          if (need <= static_cast<double>(g.memories[static_cast<std::size_t>(m)].capacity) && takes(m, nullptr)) return "";
          break;
        }
    }
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
    if (takes(m, &reason)) return "";  // d could take it: the obstacle is what else is planned
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

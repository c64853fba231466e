// Test support: build small device connectivity graphs by hand (no JSON), and an
// independent checker of the invariants of docs/architecture.md over a finished schedule.
#pragma once
#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "sched/core/device_graph.hpp"
#include "sched/timeline/schedule.hpp"

namespace rayline::testing {

struct DcgBuilder {
  DeviceGraph g;
  DcgBuilder() {
    g.name = "test";
    g.job_types = {"RayIntersect", "Compute"};
  }
  NodeId node(const std::string& n) {
    g.nodes.push_back({n, {}, {}});
    return static_cast<NodeId>(g.nodes.size() - 1);
  }
  MemId mem(const std::string& n, Bytes cap = Bytes(1) << 40, MemoryKind k = MemoryKind::Host, NodeId node = 0) {
    g.memories.push_back({n, k, cap, node});
    if (node >= 0 && static_cast<std::size_t>(node) < g.nodes.size())
      g.nodes[static_cast<std::size_t>(node)].memories.push_back(static_cast<MemId>(g.memories.size() - 1));
    return static_cast<MemId>(g.memories.size() - 1);
  }
  DeviceId dev(const std::string& n, MemId m, ComputeKind k = ComputeKind::Cpu) {
    g.computes.push_back({n, n, k, m, g.memories[m].node});
    const NodeId node = g.memories[m].node;
    if (node >= 0 && static_cast<std::size_t>(node) < g.nodes.size())
      g.nodes[static_cast<std::size_t>(node)].computes.push_back(static_cast<DeviceId>(g.computes.size() - 1));
    return static_cast<DeviceId>(g.computes.size() - 1);
  }
  ResourceId resource(const std::string& n, double bw) {
    g.resources.push_back({n, bw});
    return static_cast<ResourceId>(g.resources.size() - 1);
  }
  // A directed channel on its own resource.
  ChannelId channel(MemId a, MemId b, double bw, Time lat = 0, std::vector<ResourceId> res = {}) {
    if (res.empty()) res.push_back(resource(g.memories[a].name + "->" + g.memories[b].name, bw));
    g.channels.push_back({g.memories[a].name + "->" + g.memories[b].name, "test", a, b, lat, bw, res});
    return static_cast<ChannelId>(g.channels.size() - 1);
  }
  // Half duplex: both directions share one resource.
  void half_duplex(MemId a, MemId b, double bw, Time lat = 0) {
    const ResourceId r = resource(g.memories[a].name + "<->" + g.memories[b].name, bw);
    channel(a, b, bw, lat, {r});
    channel(b, a, bw, lat, {r});
  }
  void full_duplex(MemId a, MemId b, double bw, Time lat = 0) {
    channel(a, b, bw, lat);
    channel(b, a, bw, lat);
  }
  // Make every device run job type j at `rate` bytes/s of `kind` input with `setup` s.
  void timing(JobTypeId j, DataKind kind, double bytes_per_s, Time setup = 0) {
    g.finalize();
    for (std::size_t d = 0; d < g.computes.size(); ++d) {
      auto& c = g.timing.at(static_cast<DeviceId>(d), j);
      c.supported = true;
      c.setup = setup;
      c.rate[static_cast<int>(kind)] = 1.0 / bytes_per_s;
    }
  }
  DeviceGraph build() {
    g.finalize();
    return g;
  }
};

// n nodes of the paper's type A in miniature: a disk (150 MB/s SATA, half duplex), 8 GiB of
// RAM with one CPU device, optionally a 6 GiB GPU memory (12 GB/s PCIe) with a GPU, and a
// LAN channel between every two RAMs at the slower of the two nodes' `lan` speeds (125 MB/s
// each by default), 100 us. Every device runs job type 0 on ray queues at 32 MB/s, 5 us.
struct Cluster {
  DeviceGraph g;
  std::vector<MemId> disk, ram, gpu;
  std::vector<DeviceId> cpu, gpudev;
  explicit Cluster(int n, bool with_gpu, std::vector<double> lan = {}) {
    lan.resize(static_cast<std::size_t>(n), 125e6);
    DcgBuilder b;
    for (int i = 0; i < n; ++i) {
      const std::string p = "n" + std::to_string(i);
      const NodeId nd = b.node(p);
      disk.push_back(b.mem(p + ".disk", Bytes(1) << 40, MemoryKind::Disk, nd));
      ram.push_back(b.mem(p + ".ram", Bytes(8) << 30, MemoryKind::Host, nd));
      b.half_duplex(disk.back(), ram.back(), 150e6, 0.01);
      cpu.push_back(b.dev(p + ".cpu0", ram.back()));
      if (with_gpu) {
        gpu.push_back(b.mem(p + ".gpumem", Bytes(6) << 30, MemoryKind::Gpu, nd));
        b.full_duplex(ram.back(), gpu.back(), 12e9, 1e-5);
        gpudev.push_back(b.dev(p + ".gpu", gpu.back(), ComputeKind::Gpu));
      }
    }
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i)
      for (std::size_t j = 0; j < static_cast<std::size_t>(n); ++j)
        if (i != j) b.channel(ram[i], ram[j], std::min(lan[i], lan[j]), 1e-4);
    b.timing(0, DataKind::RayQueue, 32e6, 5e-6);
    g = b.build();
  }
};

// Blocks and jobs for hand-built states.
inline BlockId add_block(JobPool& pool, const std::string& name, DataKind kind, Bytes bytes) {
  DataBlock d;
  d.name = name;
  d.kind = kind;
  d.bytes = bytes;
  d.consumed = is_consumed_by_use(kind);
  return pool.add_block(d);
}
inline JobId add_job(JobPool& pool, const std::string& name, JobTypeId type, std::vector<BlockId> in,
                     std::vector<BlockId> out = {}, Time created = 0) {
  Job j;
  j.name = name;
  j.type = type;
  j.inputs = std::move(in);
  j.outputs = std::move(out);
  j.created = created;
  return pool.add_job(std::move(j));
}

// Independent checks over a schedule, from its activity list and eviction log only.
struct PlanCheck {
  std::vector<std::string> errors;
  void fail(std::string s) { if (errors.size() < 20) errors.push_back(std::move(s)); }
};

inline PlanCheck check_schedule(const Schedule& s, const JobPool& pool) {
  PlanCheck out;
  const DeviceGraph& g = s.graph();
  const double eps = 1e-9;
  // 1. No overlap on any timeline.
  auto check_tl = [&](const Timeline& tl, const std::string& what) {
    for (std::size_t i = 1; i < tl.items.size(); ++i) {
      const Activity& p = s.activity(tl.items[i - 1]);
      const Activity& a = s.activity(tl.items[i]);
      if (a.start < p.end - eps) out.fail(what + ": activity " + std::to_string(tl.items[i]) + " overlaps its predecessor");
    }
  };
  for (std::size_t d = 0; d < g.computes.size(); ++d) check_tl(s.device_timeline(static_cast<DeviceId>(d)), g.computes[d].name);
  for (std::size_t r = 0; r < g.resources.size(); ++r) check_tl(s.resource_timeline(static_cast<ResourceId>(r)), g.resources[r].name);

  // 2. Residency intervals per (block, mem), rebuilt from transfers / E-jobs / evictions.
  struct Stay { Time reserve, arrive, leave; };
  std::map<std::pair<BlockId, MemId>, std::vector<Stay>> stays;
  // Initial copies are those at mems no activity delivered to: reconstruct from the pool's
  // blocks with no producer job whose first use reads from a memory without a transfer in.
  // Evictions are replayed in commit order: each closes the stay that was current when the
  // activity needing the room was committed.
  std::vector<std::vector<const Eviction*>> evictions_at(s.activity_count() + 1);
  for (const Eviction& e : s.evictions())
    if (e.for_activity >= 0 && static_cast<std::size_t>(e.for_activity) < s.activity_count())
      evictions_at[static_cast<std::size_t>(e.for_activity)].push_back(&e);
  for (ActivityId id = 0; id < static_cast<ActivityId>(s.activity_count()); ++id) {
    for (const Eviction* e : evictions_at[static_cast<std::size_t>(id)]) {
      auto it = stays.find({e->block, e->mem});
      if (it == stays.end() || it->second.empty()) continue;  // an initial copy never used
      Time at = 0;  // actual time: the end of the copy's producer and users
      for (ActivityId a : e->after) at = std::max(at, s.activity(a).end);
      Stay& st = it->second.back();
      st.leave = std::min(st.leave, at);
    }
    const Activity& a = s.activity(id);
    if (a.cancelled) continue;  // withdrawn (Schedule::cancel): no copy, no residency needed
    if (a.kind == ActivityKind::Transfer) {
      const Channel& c = g.channels[a.channel];
      stays[{a.block, c.to}].push_back({a.start, a.end, kNever});
      if (a.move) {
        auto& v = stays[{a.block, c.from}];
        if (!v.empty()) v.back().leave = std::min(v.back().leave, a.end);
      }
    } else {
      const MemId m = g.computes[a.device].memory;
      for (BlockId o : pool.job(a.job).outputs) stays[{o, m}].push_back({a.start, a.end, kNever});
      for (BlockId b : pool.job(a.job).inputs) {
        auto it = stays.find({b, m});
        const bool initial = it == stays.end() || it->second.empty();
        if (initial) {
          stays[{b, m}].push_back({0, 0, kNever});
          it = stays.find({b, m});
        }
        Stay& st = it->second.back();
        if (st.arrive > a.start + eps) out.fail("E-job " + pool.job(a.job).name + " starts before input " + pool.block(b).name + " is resident");
        if (pool.block(b).consumed) st.leave = std::min(st.leave, a.end);
      }
    }
  }
  // Every E-job input must stay until the job ends.
  for (ActivityId id = 0; id < static_cast<ActivityId>(s.activity_count()); ++id) {
    const Activity& a = s.activity(id);
    if (a.kind != ActivityKind::Exec || a.cancelled) continue;
    const MemId m = g.computes[a.device].memory;
    for (BlockId b : pool.job(a.job).inputs) {
      const auto& v = stays[{b, m}];
      bool ok = false;
      for (const Stay& st : v) ok = ok || (st.arrive <= a.start + eps && st.leave >= a.end - eps);
      if (!ok) out.fail("input " + pool.block(b).name + " of " + pool.job(a.job).name + " not resident for the whole E-job");
    }
  }
  // 3. Capacity: sweep reservations per memory device (initial copies that were never used
  // are not visible here; tests size capacities so that initial copies are accounted).
  std::map<MemId, std::vector<std::pair<Time, double>>> sweep;
  for (const auto& [key, v] : stays)
    for (const Stay& st : v) {
      sweep[key.second].push_back({st.reserve, static_cast<double>(pool.block(key.first).bytes)});
      if (st.leave != kNever) sweep[key.second].push_back({st.leave, -static_cast<double>(pool.block(key.first).bytes)});
    }
  for (auto& [m, ev] : sweep) {
    std::sort(ev.begin(), ev.end(), [](auto& a, auto& b) { return a.first != b.first ? a.first < b.first : a.second < b.second; });
    double cur = 0;
    for (auto& [t, delta] : ev) {
      cur += delta;
      if (cur > static_cast<double>(g.memories[m].capacity) + 0.5)
        out.fail(g.memories[m].name + " over capacity at t=" + std::to_string(t));
    }
  }
  // Withdrawn activities produce nothing: no live activity may read what one would have made
  // (a cancelled T-job's destination copy, a cancelled E-job's outputs).
  for (ActivityId id = 0; id < static_cast<ActivityId>(s.activity_count()); ++id) {
    const Activity& a = s.activity(id);
    if (a.cancelled) {
      // (An activity a fault stopped while it ran, Schedule::fail, did take time.)
      if (a.state != ActivityState::Failed && a.end - a.start > eps)
        out.fail("withdrawn activity " + std::to_string(id) + " took time");
      continue;
    }
    // What it reads: (block, memory) pairs; a dependency that delivers one of them is where
    // it reads it from, unless a live activity among its dependencies delivers it too (a
    // cancelled one may also be a dependency for its reserved room, Schedule::cancel).
    std::vector<std::pair<BlockId, MemId>> reads;
    if (a.kind == ActivityKind::Transfer) {
      reads.emplace_back(a.block, g.channels[a.channel].from);
    } else {
      for (BlockId b : pool.job(a.job).inputs) reads.emplace_back(b, g.computes[a.device].memory);
    }
    auto delivers = [&](const Activity& c, BlockId b, MemId m) {
      if (c.kind == ActivityKind::Transfer) return c.block == b && g.channels[c.channel].to == m;
      const auto& outs = pool.job(c.job).outputs;
      return g.computes[c.device].memory == m && std::find(outs.begin(), outs.end(), b) != outs.end();
    };
    for (auto [b, m] : reads) {
      bool live = false, withdrawn = false;
      for (ActivityId p : a.deps) {
        if (!delivers(s.activity(p), b, m)) continue;
        (s.activity(p).cancelled ? withdrawn : live) = true;
      }
      if (withdrawn && !live)
        out.fail("activity " + std::to_string(id) + " reads " + pool.block(b).name + " from a withdrawn activity");
    }
  }
  // 4. Every non-discarded job has exactly one E-job (not counting those a fault aborted).
  std::vector<int> count(pool.job_count(), 0);
  for (ActivityId id = 0; id < static_cast<ActivityId>(s.activity_count()); ++id)
    if (s.activity(id).kind == ActivityKind::Exec && s.activity(id).state != ActivityState::Failed) ++count[s.activity(id).job];
  for (std::size_t j = 0; j < pool.job_count(); ++j)
    if (pool.state(static_cast<JobId>(j)) != JobState::Discarded && count[j] != 1)
      out.fail("job " + pool.job(static_cast<JobId>(j)).name + " has " + std::to_string(count[j]) + " E-jobs");
  return out;
}

inline Time makespan(const Schedule& s) {
  Time t = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i) t = std::max(t, s.activity(static_cast<ActivityId>(i)).end);
  return t;
}

// Three nodes (disk, RAM, GPU memory; two CPU threads and a GPU each) on a LAN, timed for
// RayIntersect (job type 0): the ray-stream tests' cluster.
inline DeviceGraph three_node_stream_cluster() {
  DcgBuilder b;
  std::vector<MemId> rams;
  for (int i = 0; i < 3; ++i) {
    const std::string p = "n" + std::to_string(i);
    const NodeId n = b.node(p);
    const MemId disk = b.mem(p + ".disk", Bytes(1) << 40, MemoryKind::Disk, n);
    const MemId ram = b.mem(p + ".ram", Bytes(2) << 30, MemoryKind::Host, n);
    const MemId gpu = b.mem(p + ".gpumem", Bytes(1) << 30, MemoryKind::Gpu, n);
    b.half_duplex(disk, ram, 150e6, 0.01);
    b.full_duplex(ram, gpu, 12e9, 1e-5);
    for (int c = 0; c < 2; ++c) b.dev(p + ".cpu" + std::to_string(c), ram);
    b.dev(p + ".gpu", gpu, ComputeKind::Gpu);
    rams.push_back(ram);
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (i != j) b.channel(rams[static_cast<std::size_t>(i)], rams[static_cast<std::size_t>(j)], 125e6, 1e-4);
  b.g.finalize();
  for (std::size_t d = 0; d < b.g.computes.size(); ++d) {
    auto& c = b.g.timing.at(static_cast<DeviceId>(d), 0);
    c.supported = true;
    const bool gpu = b.g.computes[d].kind == ComputeKind::Gpu;
    c.setup = gpu ? 5e-5 : 5e-6;
    c.rate[static_cast<int>(DataKind::RayQueue)] = 1.0 / (64 * (gpu ? 10e6 : 0.5e6));
  }
  return b.build();
}

}  // namespace rayline::testing

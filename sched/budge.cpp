#include "sched/budge.hpp"

#include <algorithm>
#include <chrono>

namespace rayline {

std::string BudgeScheduler::describe() const {
  return std::string("budge2009{image-space nodes; greedy per idle device; resident_first=") +
         (opt_.resident_first ? "1" : "0") + "; largest_queue=" + (opt_.largest_queue ? "1" : "0") +
         "; gpu_preferred=" + (opt_.gpu_preferred ? "1" : "0") + "; cache=" + (opt_.lru ? "LRU" : "queue-aware") + "}";
}

namespace {
// The node a job belongs to (image-space decomposition): where its non-scene inputs are.
NodeId home_node(const Job& job, const JobPool& pool, const Schedule& s) {
  for (BlockId b : job.inputs) {
    if (pool.block(b).kind == DataKind::SceneData) continue;
    for (const Copy& c : s.copies(b)) return s.graph().memories[c.mem].node;
  }
  return kNone;  // scene-only job: any node
}
}  // namespace

PlanStats BudgeScheduler::plan(Time now, JobPool& pool, Schedule& s) {
  const auto t0 = std::chrono::steady_clock::now();
  PlanStats st;
  if (bound_ != &s || !placer_) {
    placer_ = std::make_unique<Placer>(s);
    bound_ = &s;
  }
  s.set_eviction_policy(opt_.lru ? Schedule::EvictionPolicy::Lru : Schedule::EvictionPolicy::QueueAware);
  s.reproject(now);
  placer_->finder().clear();
  placer_->finder().set_now(now);
  placer_->finder().set_scene_from_origin_or_local(true);  // no scene data between nodes
  const DeviceGraph& g = s.graph();
  // Greedy: each idle device takes one job, GPUs first (they are preferred for intersection).
  std::vector<DeviceId> idle;
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    if (s.unfinished_on_device(static_cast<DeviceId>(d)) == 0) idle.push_back(static_cast<DeviceId>(d));
  std::stable_sort(idle.begin(), idle.end(), [&](DeviceId a, DeviceId b) {
    return g.computes[a].kind == ComputeKind::Gpu && g.computes[b].kind != ComputeKind::Gpu;
  });
  for (DeviceId d : idle) {
    const MemId m = g.computes[d].memory;
    const NodeId node = g.computes[d].node;
    // A GPU of this node that is idle now (it will take intersection work it can hold).
    MemId idle_gpu_mem = kNone;
    if (opt_.gpu_preferred && g.computes[d].kind == ComputeKind::Cpu)
      for (DeviceId o : g.nodes[static_cast<std::size_t>(node)].computes)
        if (g.computes[o].kind == ComputeKind::Gpu && s.unfinished_on_device(o) == 0) idle_gpu_mem = g.computes[o].memory;
    JobId best = kNone;
    bool best_resident = false;
    Bytes best_rays = 0;
    for (JobId j : pool.queued()) {
      const Job& job = pool.job(j);
      if (!g.timing.supports(d, job.type)) continue;
      const NodeId home = home_node(job, pool, s);
      if (home != kNone && home != node) continue;  // image-space decomposition
      bool resident = true;
      Bytes rays = 0, scene = 0;
      for (BlockId b : job.inputs) {
        if (pool.block(b).kind == DataKind::SceneData) {
          resident = resident && s.copy_at(b, m) != nullptr;
          scene += pool.block(b).bytes;
        } else {
          rays += pool.block(b).bytes;
        }
      }
      if (idle_gpu_mem != kNone && scene > 0 && scene <= g.memories[idle_gpu_mem].capacity) continue;  // GPU's
      if (placer_->earliest_start(j, d, now, s) == kNever) continue;
      bool better;
      if (best == kNone) better = true;
      else if (opt_.resident_first && resident != best_resident) better = resident;
      else if (opt_.largest_queue && rays != best_rays) better = rays > best_rays;
      else better = false;  // FIFO among equals
      if (better) {
        best = j;
        best_resident = resident;
        best_rays = rays;
      }
    }
    if (best != kNone) placer_->place(best, d, std::max(now, s.device_timeline(d).busy_until), now, pool, s, st);
  }
  st.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace rayline

#include "sched/policy/budge.hpp"

#include "sched/policy/image_split.hpp"

#include <algorithm>
#include <chrono>

namespace rayline {

std::string BudgeScheduler::describe() const {
  return std::string("budge2009{image-space nodes; greedy per idle device; resident_first=") +
         (opt_.resident_first ? "1" : "0") + "; largest_queue=" + (opt_.largest_queue ? "1" : "0") +
         "; gpu_preferred=" + (opt_.gpu_preferred ? "1" : "0") + "; cache=" + (opt_.lru ? "LRU" : "queue-aware") +
         "; image_split=" + (opt_.split_by_throughput ? "by-throughput" : "equal") + "}";
}

NodeId budge_image_node(JobId j, const DeviceGraph& g, bool split_by_throughput) {
  // Weight of a node: its devices' peak RayIntersect throughput, or 1 per node with a
  // compute device for an equal split; nodes without compute devices get nothing.
  std::vector<double> w = node_ray_throughput(g);
  if (!split_by_throughput || g.job_type("RayIntersect") == kNone) {
    w.assign(g.nodes.size(), 0.0);
    for (const ComputeDevice& c : g.computes)
      if (c.node >= 0 && static_cast<std::size_t>(c.node) < w.size()) w[static_cast<std::size_t>(c.node)] = 1.0;
  }
  return static_cast<NodeId>(weighted_pick(static_cast<std::uint64_t>(j), w));
}

namespace {
// The node a job belongs to (image-space decomposition): where its non-scene inputs are;
// a GenerateRays job on a client's request (only Generic inputs) belongs to the node its
// part of the image is assigned to.
NodeId home_node(JobId j, const Job& job, const JobPool& pool, const Schedule& s, bool by_throughput) {
  const DeviceGraph& g = s.graph();
  bool generic_only = !job.inputs.empty();
  for (BlockId b : job.inputs) generic_only = generic_only && pool.block(b).kind == DataKind::Generic;
  if (generic_only && g.job_types[static_cast<std::size_t>(job.type)] == "GenerateRays")
    return budge_image_node(j, g, by_throughput);
  for (BlockId b : job.inputs) {
    if (pool.block(b).kind == DataKind::SceneData) continue;
    for (const Copy& c : s.copies(b)) return g.memories[c.mem].node;
  }
  return kNone;  // scene-only job: any node
}
}  // namespace

Bytes BudgeScheduler::rays_of(Queued& q, const JobPool& pool) {
  if (q.live_rays || q.seen != pool.input_count(q.job)) {
    const InputSummaries::Summary& in = inputs_.of(q.job, pool);
    q.rays = inputs_.rays(q.job, pool);
    q.seen = static_cast<std::uint32_t>(in.seen);
    q.live_rays = !in.live.empty();
  }
  return q.rays;
}

PlanStats BudgeScheduler::plan(Time now, JobPool& pool, Schedule& s) {
  const auto t0 = std::chrono::steady_clock::now();
  PlanStats st;
  if (bound_ != &s || !placer_) {
    placer_ = std::make_unique<Placer>(s);
    bound_ = &s;
    homes_.clear();
    inputs_.clear();
    by_node_.clear();
  }
  s.set_eviction_policy(opt_.lru ? Schedule::EvictionPolicy::Lru : Schedule::EvictionPolicy::QueueAware);
  const DeviceGraph& g = s.graph();
  // Greedy: each idle device takes one job, GPUs first (they are preferred for intersection).
  // Nothing idle or nothing queued: nothing to decide (most events of a busy run).
  std::vector<DeviceId> idle;
  if (pool.queued_count() > 0)
    for (std::size_t d = 0; d < g.computes.size(); ++d)
      if (s.unfinished_on_device(static_cast<DeviceId>(d)) == 0 && s.compute_alive(static_cast<DeviceId>(d)))
        idle.push_back(static_cast<DeviceId>(d));
  if (idle.empty()) {
    st.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return st;
  }
  s.reproject(now);
  placer_->finder().clear();
  placer_->finder().set_now(now);
  placer_->finder().set_scene_from_origin_or_local(true);  // no scene data between nodes
  std::stable_sort(idle.begin(), idle.end(), [&](DeviceId a, DeviceId b) {
    return g.computes[a].kind == ComputeKind::Gpu && g.computes[b].kind != ComputeKind::Gpu;
  });
  std::vector<Cand>& cand = cand_;
  // A job's home node never changes once known (its rays never leave their node), so it is
  // remembered across calls; "any node" (kNone) is recomputed.
  if (homes_.size() < pool.job_count()) homes_.resize(pool.job_count(), kNone);
  // A node whose compute devices are all lost (Schedule::fail) is home to nothing: its
  // jobs belong to any node.
  auto node_alive = [&](NodeId n) {
    for (DeviceId d : g.nodes[static_cast<std::size_t>(n)].computes)
      if (s.compute_alive(d)) return true;
    return false;
  };
  auto home_of = [&](JobId j) {
    NodeId& h = homes_[static_cast<std::size_t>(j)];
    if (h == kNone) h = home_node(j, pool.job(j), pool, s, opt_.split_by_throughput);
    return h != kNone && s.any_lost() && !node_alive(h) ? kNone : h;
  };
  // The buckets (budge.hpp): the jobs queued since the last call join their home's bucket;
  // once a device is lost, homes can change at any call, so every queued job is bucketed
  // again at each.
  const std::size_t any_bucket = g.nodes.size();
  if (by_node_.size() != g.nodes.size() + 1 || s.any_lost()) {
    by_node_.assign(g.nodes.size() + 1, {});
    bucketed_ = 0;
  }
  for (JobId j : pool.queued_since(bucketed_)) {
    const NodeId home = home_of(j);
    const InputSummaries::Summary& in = inputs_.of(j, pool);
    Bytes scene = 0;
    for (BlockId b : in.scene) scene += pool.block(b).bytes;
    by_node_[home == kNone ? any_bucket : static_cast<std::size_t>(home)].push_back(
        {j, pool.queue_number(j), in.scene.size() == 1 ? in.scene[0] : kNone, scene, in.scene.size() > 1, false,
         pool.job(j).type, ~std::uint32_t{0}, 0});  // (rays summed at the first read)
  }
  bucketed_ = pool.appended();
  for (DeviceId d : idle) {
    const MemId m = g.computes[d].memory;
    const NodeId node = g.computes[d].node;
    // A GPU of this node that is idle now (it will take intersection work it can hold).
    MemId idle_gpu_mem = kNone;
    if (opt_.gpu_preferred && g.computes[d].kind == ComputeKind::Cpu)
      for (DeviceId o : g.nodes[static_cast<std::size_t>(node)].computes)
        if (g.computes[o].kind == ComputeKind::Gpu && s.unfinished_on_device(o) == 0 && s.compute_alive(o)) idle_gpu_mem = g.computes[o].memory;
    // Candidates of this device with their keys; feasibility (a fetch-path search) is
    // checked only in priority order, so the first feasible one is the same pick as the
    // best feasible one: resident first, then the largest queue, then queue order.
    cand.clear();
    // The job types d runs, as bits (the scan asks for every queued job).
    std::uint64_t runs = 0;
    bool runs_all_known = g.job_types.size() <= 64;
    for (std::size_t t = 0; runs_all_known && t < g.job_types.size(); ++t)
      if (g.timing.supports(d, static_cast<JobTypeId>(t))) runs |= std::uint64_t{1} << t;
    auto supported = [&](JobTypeId t) {
      return runs_all_known ? t >= 0 && (runs >> static_cast<unsigned>(t) & 1) != 0 : g.timing.supports(d, t);
    };
    for (const std::size_t k : {static_cast<std::size_t>(node), any_bucket}) {
      std::vector<Queued>& bucket = by_node_[k];
      std::size_t keep = 0;  // entries of jobs still queued under the same number, in order
      for (std::size_t i = 0; i < bucket.size(); ++i) {
        if (pool.queue_number(bucket[i].job) != bucket[i].number) continue;  // planned, or queued again later
        Queued* qp = nullptr;  // the entry as kept, whose cached rays rays_of() refreshes
        if (k == any_bucket) {
          // "Any node" until its inputs say where it belongs (home_of is asked again).
          if (const NodeId h = home_of(bucket[i].job); h != kNone) {
            std::vector<Queued>& to = by_node_[static_cast<std::size_t>(h)];
            to.push_back(bucket[i]);  // order: `number` decides, not the bucket
            if (h != node) continue;
            qp = &to.back();
          } else {
            bucket[keep] = bucket[i];
            qp = &bucket[keep++];
          }
        } else {
          bucket[keep] = bucket[i];
          qp = &bucket[keep++];
        }
        Queued& q = *qp;
        if (!supported(q.type)) continue;
        bool resident = true;
        const Bytes scene = q.scene_bytes;
        if (q.many_scenes) {
          for (BlockId b : inputs_.of(q.job, pool).scene) resident = resident && s.copy_at(b, m) != nullptr;
        } else if (q.scene0 != kNone) {
          resident = s.copy_at(q.scene0, m) != nullptr;
        }
        if (idle_gpu_mem != kNone && scene > 0 && scene <= g.memories[idle_gpu_mem].capacity) continue;  // GPU's
        Bytes rays = 0;
        if (opt_.largest_queue) rays = rays_of(q, pool);
        cand.push_back({q.job, opt_.resident_first && resident, rays, static_cast<std::size_t>(q.number)});
      }
      bucket.resize(keep);
    }
    // Candidates in priority order until one is feasible: a heap, since usually the first
    // one is (a full sort of thousands of queued jobs per idle device was most of a plan).
    // `pos` is unique, so the order is total and the same as sorting.
    auto after = [](const Cand& a, const Cand& b) {  // a comes after b
      if (a.resident != b.resident) return b.resident;
      if (a.rays != b.rays) return a.rays < b.rays;
      return a.pos > b.pos;
    };
    // The first in that order is usually feasible: found by one pass, the heap only if not.
    JobId best = kNone;
    if (!cand.empty()) {
      std::size_t top = 0;
      for (std::size_t i = 1; i < cand.size(); ++i)
        if (after(cand[top], cand[i])) top = i;
      if (placer_->earliest_start(cand[top].job, d, now, s) != kNever) best = cand[top].job;
    }
    if (best == kNone) std::make_heap(cand.begin(), cand.end(), after);
    for (auto end = cand.end(); best == kNone && end != cand.begin(); --end) {
      std::pop_heap(cand.begin(), end, after);
      const Cand& c = *(end - 1);
      if (placer_->earliest_start(c.job, d, now, s) != kNever) {
        best = c.job;
        break;
      }
    }
    if (best != kNone) placer_->place(best, d, std::max(now, s.device_timeline(d).busy_until), now, pool, s, st);
  }
  st.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace rayline

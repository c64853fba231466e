// Budge et al. 2009 as Son & Yoon describe it (Sec. 6): image-space decomposition over
// nodes, and inside a node out-of-core ray batching over its CPU threads and GPU with
// case-by-case priority rules. The original rules are not public (docs/baselines.md,
// Sec. 1), so they are explicit parameters, printed with every result (describe()):
//   * image space: a ray queue is processed on the node that holds it (rays never cross
//     the LAN) and scene data comes from that node's own disk or cache;
//   * greedy dispatch: whenever a device is idle it takes one job (no planning horizon);
//   * priority: jobs whose scene block is already resident on the device's memory first,
//     then the largest queue (most rays); ties to the older job;
//   * GPU preference: a CPU leaves an intersection job whose block fits in a GPU memory
//     of its node to that GPU while the GPU is idle or about to be;
//   * caches: LRU eviction on every memory device;
//   * image split: a GenerateRays job on a client's request (only Generic inputs)
//     belongs to a node fixed by its id, like a tile of the image: by default in proportion to each node's peak RayIntersect throughput (the split a
//     careful user of a heterogeneous cluster would choose; kinder to the baseline than
//     an equal split, which is the other setting). Without this rule every ray would
//     start, and stay, on the client's node.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "sched/policy/input_summary.hpp"
#include "sched/policy/placer.hpp"
#include "sched/policy/scheduler.hpp"

namespace rayline {

struct BudgeOptions {
  bool resident_first = true;   // rule 1: data already resident
  bool largest_queue = true;    // rule 2: then the largest queue (else FIFO)
  bool gpu_preferred = true;    // rule 3: intersection on the GPU when the block fits
  bool lru = true;              // caches: LRU
  bool split_by_throughput = true;  // image split over nodes: by peak ray throughput (else equal)
};

// The image-space decomposition: the node (index into g.nodes) that owns ray-starting job
// `j`, a pure function of the job id and the platform (weights: a node's summed peak
// RayIntersect throughput, or 1 per node with a compute device). Exposed for unit tests.
NodeId budge_image_node(JobId j, const DeviceGraph& g, bool split_by_throughput);


class BudgeScheduler final : public Scheduler {
 public:
  explicit BudgeScheduler(BudgeOptions o = {}) : opt_(o) {}
  std::string name() const override { return "budge"; }
  std::string describe() const override;  // the rule parameters, for every result
  PlanStats plan(Time now, JobPool& pool, Schedule& schedule) override;

 private:
  BudgeOptions opt_;
  const Schedule* bound_ = nullptr;
  std::unique_ptr<Placer> placer_;
  std::vector<NodeId> homes_;  // per job: its node under the image-space decomposition
  InputSummaries inputs_;  // per job: its scene blocks and ray bytes
  // Queued jobs bucketed by home node (the last bucket: any node), in queue order, kept
  // across calls: each call adds the jobs queued since the last one and drops, while
  // scanning a bucket, entries whose job left the queue (or was queued again: a new
  // number). After a lost device (homes can change) they are rebuilt at every call.
  // An entry holds what the scan reads, so that it reads the pool only for the queue
  // number and the input count (dense arrays), not the job: its type never changes, and
  // its ray bytes are refreshed when a merge added inputs (or, with inputs whose bytes can
  // change, at every read).
  struct Queued {
    JobId job;
    std::int64_t number;  // its append number in the queue (the queue order)
    BlockId scene0;       // its one scene input (kNone: none, or several: see inputs_)
    Bytes scene_bytes;    // all its scene inputs
    bool many_scenes;
    bool live_rays;       // inputs whose bytes can change: rays summed at every read
    JobTypeId type;
    std::uint32_t seen;   // the input count `rays` was summed at
    Bytes rays;           // its non-scene input bytes (InputSummaries::rays)
  };
  Bytes rays_of(Queued& q, const JobPool& pool);
  std::vector<std::vector<Queued>> by_node_;
  struct Cand {  // a device's candidate with its priority key (plan())
    JobId job;
    bool resident;
    Bytes rays;
    std::size_t pos;
  };
  std::vector<Cand> cand_;  // (kept: its capacity outlives a plan)
  std::int64_t bucketed_ = 0;  // queue numbers below this are in by_node_
};

}  // namespace rayline

// Warm start (docs/simulator.md, "Warm start"): memories begin holding scene blocks, as
// caches do after a long steady run, so a short simulation measures the steady state
// instead of the first loads from disk (the paper's Fig. 8 throughputs are steady-state
// figures; its Fig. 9 is the cold start).
//
// Placement: every memory device that a compute device works from (host RAM, GPU memory)
// takes scene blocks in order of use, most used first, while they fit in `share` of its
// capacity (a block that does not fit is skipped, a smaller later one may still fit);
// ties go to the lower block index. The copies are caches (evictable, not origins), present
// at time 0. The same blocks on every node: under a steady load that is the same on every
// node, every cache converges to the blocks used most.
#pragma once
#include <vector>

#include "sched/core/job_pool.hpp"
#include "sched/timeline/schedule.hpp"
#include "workload/scene_profile.hpp"

namespace rayline {

struct WarmStart {
  double host_share = 0.75;  // of host RAM: the rest stays free for ray queues
  double gpu_share = 0.75;   // of GPU memory
  // A policy's own steady state (scheduler_factory.hpp, warm_placement): per scene block,
  // the memories that hold it. Empty: the placement above (most used first, everywhere).
  std::vector<std::vector<MemId>> placement;
};

// Puts the copies (`opt.placement` when given, still within the shares); `use[i]` weighs scene block `blocks[i]` (higher: used more). Returns the
// number of copies placed. Never exceeds a capacity: used(m) <= share x capacity after it,
// counting what m held already.
std::size_t warm_start(Schedule& s, const JobPool& pool, const std::vector<BlockId>& blocks, const std::vector<double>& use,
                       const WarmStart& opt);

// How much each block is used per camera ray of the profile: its expected RayIntersect
// and ShadowIntersect visits (workload/ray_flow_expectation.hpp, Markov statistics).
std::vector<double> expected_block_visits(const SceneProfile& p);

}  // namespace rayline

// Rayline's own policy (docs/rayline-policy.md): GMB's timelines, timing model, Placer and
// SDC fetch paths, with data placement made part of the plan. Rule by rule:
//   1. ownership (ownership.hpp): each scene block has an owner node per replica group; a
//      ray job runs on the owner of its block in the group its rays are in, so rays move
//      to resident data and scene blocks never cross the LAN (a block a node lacks comes
//      from its own disk);
//   2. generation: a frame's rays are generated on nodes picked by an image split in
//      proportion to peak ray throughput (group first, then node in the group);
//   3. completion-aware placement: a node's jobs, in priority order (scene block already
//      resident on the node first, then the most rays, then queue order), each go to the
//      node's device that would *finish* it first (Eq. 2 and the SDC arrival of its
//      inputs), so a GPU is not left idle behind CPU threads nor a CPU thread handed a
//      job a GPU would finish sooner; among the devices whose memory already holds the
//      job's scene block when one of them can take it within the horizon;
//   4. batching: a job whose rays would cross the LAN waits until they are worth a
//      transfer (`min_remote_bytes`, so the link's latency is not paid per handful of
//      rays) or until it has waited `hold`; with `--rayline-on hold` (or rule 8) every
//      ray job, wherever its rays are, waits to hold `min_local_bytes` (or `hold`) while
//      a device of its node runs something, so devices trace queues, not handfuls of rays;
//   5. no waiting in line: a job that would leave its device waiting for data longer than
//      its own run (and than `slack`) is taken only after the jobs that can start at once,
//      so a slow transfer does not hold up the device's timeline; and one that cannot
//      start within the horizon (its block comes from the disk) only once the node's
//      previous such job has started;
//   6. look-ahead: each device is planned up to now + horizon, so ray queues travel to
//      their owner while the device still works, and a node is planned again only once
//      one of its devices has less than half the horizon left (and, for an idle device,
//      only once something on the node changed: RaylineOptions::skip_unchanged);
//   7. device-sized jobs (job_size.hpp): a ray job stops taking merged queues once it holds
//      what the fastest device traces in a quarter of the horizon;
//   8. (off by default) camera rays made by the owners of the blocks they enter;
//   9. room: a wave of camera rays is made only where three times the rays on the memory
//      device, the wave included, leave room for the largest scene block.
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sched/policy/input_summary.hpp"
#include "sched/policy/placer.hpp"
#include "sched/policy/rayline/ownership.hpp"
#include "sched/policy/scheduler.hpp"
#include "sched/sdc/fetch_bound.hpp"

namespace rayline {

struct RaylineOptions {
  Time horizon = 0.5;            // rule 6, seconds
  bool ownership = true;         // rule 1 (off: a ray job runs where its rays are, as in Budge)
  bool image_split = true;       // rule 2 (off: rays are generated on their client's node)
  bool completion_aware = true;  // rule 3 (off: the device whose timeline ends first)
  Bytes min_remote_bytes = 256 << 10;  // rule 4 (0: off)
  Time hold = 0.1;                     // rule 4, seconds
  bool no_waiting = true;              // rule 5 (off: jobs in priority order, whatever they wait for)
  Time slack = 1e-3;                   // rule 5, seconds; also the least time between two plans of a node
  // Rule 7 (job_size.hpp): a ray job holds at most what the fastest device traces in this
  // many seconds (a quarter of the horizon; 0: off).
  Time job_seconds = 0.125;
  // Rule 8: each wave's camera rays are made by the owners of the blocks they enter (one
  // GenerateRays job per owner; needs rules 1 and 2). Off: a wave is one job, placed by rule 2.
  bool owner_generation = true;
  // Rule 4 for every ray job (with `hold`): a ray job, its rays here or elsewhere, waits
  // until it holds this many bytes of rays, idle devices or not, while a device of its
  // node runs something (0: off). rayline_options() sets it only with the "hold" rule or
  // rule 8 switched on, and rule 4 not switched off.
  Bytes min_local_bytes = 1 << 20;
  // Rule 9: a wave of camera rays is made only on a memory device where room_factor times its
  // rays (everything but scene data, the wave included) leaves room for the largest scene
  // block (rayline_scheduler.cpp, plan_node).
  bool room = true;
  double room_factor = 3;
  // Not a rule, a shortcut with the same plans: a node that is asked again only because a
  // device of it is idle, with nothing on it changed since its last plan (Schedule::
  // node_epoch, merged rays, the times its held jobs may go), is not planned again. Off:
  // every such node is planned at every call (the reference the tests compare against).
  bool skip_unchanged = true;
};

// The rules that can be switched off (docs/rayline-policy.md), for the ablation: bit i is
// rule kRaylineRuleNames[i]. rayline_rules_off("ownership,batching") gives their mask;
// std::nullopt names an unknown rule.
inline constexpr std::string_view kRaylineRuleNames[] = {"ownership", "image-split", "completion", "batching",
                                                         "no-waiting", "job-size", "generation", "hold", "room"};
constexpr unsigned rayline_rule_bit(std::string_view name) {
  for (unsigned i = 0; i < std::size(kRaylineRuleNames); ++i)
    if (kRaylineRuleNames[i] == name) return 1u << i;
  return 0;
}
std::optional<unsigned> rayline_rules_off(std::string_view list);
// Rules off unless switched on (`--rayline-on`), which the measurements do not yet justify
// as defaults (docs/rayline-policy.md): rule 8, and rule 4's hold of every small ray job
// ("hold"; rule 8 switches it on too).
inline constexpr unsigned kRaylineRulesOffByDefault = rayline_rule_bit("generation") | rayline_rule_bit("hold");
RaylineOptions rayline_options(Time horizon, unsigned rules_off, unsigned rules_on = 0);

class RaylineScheduler final : public Scheduler {
 public:
  explicit RaylineScheduler(RaylineOptions o = {}) : opt_(o) {}
  std::string name() const override { return "rayline"; }
  std::string describe() const override;
  PlanStats plan(Time now, JobPool& pool, Schedule& schedule) override;
  const Ownership& ownership() const { return own_; }
  // Nodes not planned again because nothing on them changed (RaylineOptions::skip_unchanged).
  std::uint64_t skipped() const { return skipped_; }
  // The node job j belongs to (kNone: any node); exposed for tests.
  NodeId home(JobId j, const JobPool& pool, const Schedule& s);
  // Rule 8 (Scheduler::ray_origin): the owner of `entry` in the group that rule 2's image
  // split gives the wave.
  bool places_ray_origins() const override { return opt_.owner_generation && opt_.ownership && opt_.image_split; }
  NodeId ray_origin(std::uint64_t wave, BlockId entry, const JobPool& pool, const Schedule& s) override;

 private:
  void update_scene(const JobPool& pool, const DeviceGraph& g);
  void plan_node(std::size_t n, Time now, JobPool& pool, Schedule& s, PlanStats& st);
  template <class Visit>
  void scan_buckets(std::size_t n, JobPool& pool, const Schedule& s, Visit&& visit);
  static Time free_at(DeviceId d, Time now, const Schedule& s);  // when d can start new work

  RaylineOptions opt_;
  const Schedule* bound_ = nullptr;
  std::unique_ptr<Placer> placer_;
  std::unique_ptr<FetchBound> fetch_bound_;
  Ownership own_;
  std::vector<BlockId> scene_;             // scene blocks in id order
  Bytes largest_scene_ = 0;                // rule 9: the largest of them
  std::vector<std::pair<MemId, Bytes>> rays_on_;  // rule 9: per memory device, what no eviction frees (this plan)
  std::vector<std::pair<JobId, MemId>> waves_;    // rule 9: waves planned, not yet made, and their memory device
  std::vector<std::int32_t> scene_index_;  // per block id: its index in scene_, or -1
  std::size_t blocks_seen_ = 0;
  std::vector<double> group_weight_;
  std::vector<std::vector<double>> node_weight_;  // per group: its nodes' weights
  InputSummaries inputs_;
  std::vector<NodeId> homes_;  // per job, once known (kNone: not yet, or any node)
  std::vector<NodeId> rays_at_;  // per job: the node its rays are on (merged queues share it)
  struct Queued {
    JobId job;
    std::int64_t number;  // append number in the queue (queue order; stale once it differs)
  };
  std::vector<std::vector<Queued>> by_node_;  // last: any node
  std::int64_t bucketed_ = 0;
  std::vector<bool> fresh_;    // per bucket: jobs joined since its node was last planned
  std::vector<Time> recheck_;  // per node: when held jobs are looked at again
  std::vector<Time> planned_at_;  // per node: its last plan
  // Per node: Schedule::node_epoch() after its last plan, and whether a queued job of it
  // took merged rays since (JobPool::merged(), read up to merged_seen_).
  std::vector<std::uint64_t> seen_epoch_;
  std::vector<char> merged_into_;
  std::vector<Time> wake_at_;  // per node: when a job its last plan left for a time rule may go
  bool held_while_busy_ = false;
  std::uint64_t skipped_ = 0;  // plan_node: rule 4 held a job because the node was busy
  std::size_t merged_seen_ = 0;
  std::vector<char> stale_;  // per node: a job of its bucket left the queue since it was last pruned
  std::size_t left_seen_ = 0;  // JobPool::left_queue() read up to here
  std::vector<Time> held_until_;  // per node: when its first held job may go (-kNever: none held)
  std::vector<std::size_t> todo_;
  Time reprojected_ = -kNever;
  std::vector<JobId> long_wait_job_;  // per node: its last job placed beyond the horizon
  struct Cand {
    JobId job;
    bool resident;
    Bytes rays;
    std::int64_t number;
    DeviceId device = kNone;  // waiting: the device the first pass picked, at `ready`
    Time ready = 0;
  };
  std::vector<Cand> cand_, waiting_, far_;  // far_: rule 5's jobs whose block comes from the disk
  std::vector<std::pair<Time, DeviceId>> devices_;
  static constexpr Bytes kNoFloor = ~Bytes{0};
  std::vector<Bytes> drop_floor_;  // per memory: the least room found to drop a last copy
};

}  // namespace rayline

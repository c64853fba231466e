// Rayline's policy (sched/policy/rayline/): block ownership pinned on hand-built platforms
// and checked as properties over random ones; the scheduler's rules on hand-built states;
// the schedule invariants on random instances.
#include <gtest/gtest.h>

#include <numeric>
#include <random>
#include <set>

#include "dcg_fixture.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/policy/rayline/job_size.hpp"
#include "sched/policy/rayline/ownership.hpp"
#include "sched/policy/rayline/rayline_scheduler.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/runtime/runtime_loop.hpp"

using namespace rayline;
using rayline::testing::Cluster;

namespace {
constexpr Bytes kMB = 1'000'000;

// Every group owns every block, each node of a group one run of consecutive blocks.
void expect_runs(const Ownership& o, std::size_t blocks) {
  ASSERT_EQ(o.owner.size(), o.groups.size());
  for (std::size_t k = 0; k < o.groups.size(); ++k) {
    ASSERT_EQ(o.owner[k].size(), blocks);
    std::vector<NodeId> seen;
    for (std::size_t b = 0; b < blocks; ++b) {
      const NodeId n = o.owner[k][b];
      ASSERT_NE(std::find(o.groups[k].begin(), o.groups[k].end(), n), o.groups[k].end()) << "block " << b;
      if (b > 0 && n == o.owner[k][b - 1]) continue;
      EXPECT_EQ(std::find(seen.begin(), seen.end(), n), seen.end()) << "node " << n << " owns two runs";
      seen.push_back(n);
    }
  }
}

// A scene block on every disk (Sec. 6.1) and a ray queue for it on `rays_at`.
JobId ray_job(JobPool& pool, Schedule& s, BlockId scene, Bytes rays, MemId rays_at, const std::string& tag,
              Time created = 0) {
  const BlockId q = rayline::testing::add_block(pool, "rays" + tag, DataKind::RayQueue, rays);
  s.put_initial(q, rays_at, created, false);
  return rayline::testing::add_job(pool, "job" + tag, 0, {scene, q}, {}, created);
}

BlockId scene_block(JobPool& pool, Schedule& s, const Cluster& c, Bytes bytes, const std::string& tag) {
  const BlockId b = rayline::testing::add_block(pool, "scene" + tag, DataKind::SceneData, bytes);
  for (MemId d : c.disk) s.put_initial(b, d);
  return b;
}

// Eight 1.5 GB scene blocks (12 GB: more than one node of Cluster holds, so two nodes split them).
std::vector<BlockId> eight_blocks(JobPool& pool, Schedule& s, const Cluster& c) {
  std::vector<BlockId> scene;
  for (int b = 0; b < 8; ++b) scene.push_back(scene_block(pool, s, c, 1500 * kMB, std::to_string(b)));
  return scene;
}

// Two nodes, the eight blocks, and rays for every block on node 0 (job i reads block i),
// run to the end under Rayline's policy with `o`.
struct EightQueuesOnNode0 {
  Cluster c{2, false};
  JobPool pool;
  Schedule s{c.g, pool};
  RaylineScheduler rs;
  explicit EightQueuesOnNode0(RaylineOptions o) : rs(o) {
    const std::vector<BlockId> scene = eight_blocks(pool, s, c);
    for (int b = 0; b < 8; ++b) ray_job(pool, s, scene[static_cast<std::size_t>(b)], 4 * kMB, c.ram[0], std::to_string(b));
    ExactExecutor ex(s);
    StaticWorkload wl;
    RuntimeLoop loop(rs, ex, wl, pool, s);
    stalled = loop.run().stalled;
  }
  bool stalled = true;
  void expect_done_and_valid() {
    for (JobId j = 0; j < static_cast<JobId>(pool.job_count()); ++j) EXPECT_EQ(pool.state(j), JobState::Done);
    const auto chk = rayline::testing::check_schedule(s, pool);
    for (const auto& e : chk.errors) ADD_FAILURE() << e;
  }
};
// Two nodes (with a GPU each, or not), the eight blocks, blocks [first, last) warm in node
// `warm_node`'s RAM, and Rayline's policy with `o`, for tests that plan step by step.
struct EightBlocksWarm {
  Cluster c;
  JobPool pool;
  Schedule s{c.g, pool};
  std::vector<BlockId> scene;
  RaylineScheduler rs;
  EightBlocksWarm(bool gpu, int warm_node, int first, int last, RaylineOptions o)
      : c(2, gpu), scene(eight_blocks(pool, s, c)), rs(o) {
    for (int b = first; b < last; ++b)
      s.put_initial(scene[static_cast<std::size_t>(b)], c.ram[static_cast<std::size_t>(warm_node)], 0, false);
  }
};
}  // namespace

TEST(RaylineOwnership, ReplicatedWhenEveryNodeHoldsTheScene) {
  const Cluster c(3, true);
  const std::vector<Bytes> bytes(10, 500 * kMB);  // 5 GB: fits 8 GiB of RAM + 6 GiB of GPU memory
  const Ownership o = plan_ownership(c.g, bytes);
  EXPECT_TRUE(o.replicated());
  ASSERT_EQ(o.groups.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k)
    for (NodeId n : o.owner[k]) EXPECT_EQ(n, o.groups[k][0]);
  EXPECT_TRUE(ownership_warm_placement(o, c.g, bytes).empty()) << "replicated: the default warm start";
}

TEST(RaylineOwnership, SplitRunsStayWithinCapacityAndFollowThroughput) {
  for (int seed = 0; seed < 40; ++seed) {
    std::mt19937 rng(4100 + seed);
    const int n = 2 + seed % 5;
    const bool gpu = seed % 2 == 0;
    Cluster c(n, gpu);
    std::vector<Bytes> bytes(static_cast<std::size_t>(20 + seed % 30));
    for (Bytes& b : bytes) b = std::uniform_int_distribution<Bytes>(300 * kMB, 1500 * kMB)(rng);
    const double scene = static_cast<double>(std::accumulate(bytes.begin(), bytes.end(), Bytes{0}));
    const double whole = gpu ? 14.0 * (1 << 30) : 8.0 * (1 << 30);
    const Ownership o = plan_ownership(c.g, bytes);
    if (scene <= 0.9 * whole) {  // every node holds 90 % of the scene: replicated
      EXPECT_TRUE(o.replicated()) << seed;
      continue;
    }
    ASSERT_FALSE(o.groups.empty()) << seed;
    EXPECT_FALSE(o.replicated()) << seed;
    expect_runs(o, bytes.size());
    const double cap = 0.75 * 8.0 * (1 << 30) + (gpu ? 0.75 * 6.0 * (1 << 30) : 0.0);
    const Bytes largest = *std::max_element(bytes.begin(), bytes.end());
    for (std::size_t k = 0; k < o.groups.size(); ++k) {
      const double group_cap = cap * static_cast<double>(o.groups[k].size());
      EXPECT_TRUE(group_cap >= scene || o.groups.size() == 1) << "seed " << seed << ": a group that cannot hold the scene";
      std::vector<double> owned(c.g.nodes.size(), 0.0);
      for (std::size_t b = 0; b < bytes.size(); ++b) owned[static_cast<std::size_t>(o.owner[k][b])] += static_cast<double>(bytes[b]);
      // Equal nodes: equal shares (to a block at each end of the run), within capacity
      // (to one block) whenever the group can hold the scene.
      const double share = scene / static_cast<double>(o.groups[k].size());
      for (NodeId m : o.groups[k]) {
        EXPECT_NEAR(owned[static_cast<std::size_t>(m)], std::min(share, group_cap >= scene ? cap : share),
                    static_cast<double>(2 * largest) + 1)
            << "seed " << seed;
        if (group_cap >= scene) {
          EXPECT_LE(owned[static_cast<std::size_t>(m)], cap + static_cast<double>(largest)) << "seed " << seed;
        }
      }
    }
    // Warm placement: owners only, within the shares, and every block once per group when
    // the memories can hold the scene.
    const std::vector<std::vector<MemId>> at = ownership_warm_placement(o, c.g, bytes);
    ASSERT_EQ(at.size(), bytes.size());
    std::vector<double> used(c.g.memories.size(), 0.0);
    for (std::size_t b = 0; b < bytes.size(); ++b) {
      for (MemId m : at[b]) {
        used[static_cast<std::size_t>(m)] += static_cast<double>(bytes[b]);
        bool owner = false;
        for (const auto& ow : o.owner) owner = owner || ow[b] == c.g.memories[static_cast<std::size_t>(m)].node;
        EXPECT_TRUE(owner) << "seed " << seed << ": block " << b << " warm on a node that does not own it";
      }
    }
    for (std::size_t m = 0; m < used.size(); ++m)
      EXPECT_LE(used[m], 0.75 * static_cast<double>(c.g.memories[m].capacity) + 1) << "seed " << seed;
  }
}

TEST(RaylineOwnership, ANodeOnASlowLinkOwnsNothing) {
  // Node 2's link (1 MB/s) carries less than a tenth of its ray throughput (32 + 32 MB/s
  // at lan_reuse 4): it takes part in no group; the other two own everything.
  const Cluster c(3, true, {125e6, 125e6, 1e6});
  const std::vector<Bytes> bytes(20, 1000 * kMB);
  const Ownership o = plan_ownership(c.g, bytes);
  EXPECT_EQ(o.group_of_node[2], -1);
  EXPECT_EQ(o.weight[2], 0.0);
  for (const auto& owner : o.owner)
    for (NodeId n : owner) EXPECT_NE(n, 2);
  // At 125 MB/s x 4 the others keep their full throughput, 64 MB/s each.
  EXPECT_DOUBLE_EQ(o.weight[0], 64e6);
  const std::vector<double> lan = node_lan_bandwidth(c.g);
  EXPECT_DOUBLE_EQ(lan[0], 125e6);
  EXPECT_DOUBLE_EQ(lan[2], 1e6);
}

TEST(Rayline, RayJobsRunOnTheirBlocksOwnerAndSceneDataNeverCrossesTheLan) {
  EightQueuesOnNode0 r{RaylineOptions{}};  // node 1's blocks: their rays cross the LAN
  ASSERT_FALSE(r.stalled);
  const Ownership& o = r.rs.ownership();
  ASSERT_FALSE(o.replicated());
  int crossed = 0;
  for (std::size_t i = 0; i < r.s.activity_count(); ++i) {
    const Activity& a = r.s.activity(static_cast<ActivityId>(i));
    if (a.kind == ActivityKind::Exec) {
      const std::size_t b = static_cast<std::size_t>(a.job);  // job i reads scene[i]
      EXPECT_EQ(r.c.g.computes[a.device].node, o.owner[0][b]) << "job " << a.job;
      continue;
    }
    const Channel& ch = r.c.g.channels[a.channel];
    if (r.c.g.memories[ch.from].node == r.c.g.memories[ch.to].node) continue;
    EXPECT_EQ(r.pool.block(a.block).kind, DataKind::RayQueue);
    ++crossed;
  }
  EXPECT_EQ(crossed, 4);  // node 1 owns the second half
  r.expect_done_and_valid();
}

TEST(Rayline, CompletionAwareChoiceTakesTheDeviceThatFinishesFirst) {
  for (const bool completion_aware : {true, false}) {
    Cluster c(1, true);
    c.g.timing.at(c.gpudev[0], 0).rate[static_cast<int>(DataKind::RayQueue)] = 1.0 / 640e6;  // 20x the CPU
    JobPool pool;
    Schedule s(c.g, pool);
    const BlockId sc = scene_block(pool, s, c, 100 * kMB, "0");
    s.put_initial(sc, c.ram[0], 0, false);
    s.put_initial(sc, c.gpu[0], 0, false);
    const JobId j = ray_job(pool, s, sc, 64 * kMB, c.ram[0], "0");
    RaylineScheduler rs(RaylineOptions{.completion_aware = completion_aware});
    rs.plan(0, pool, s);
    ASSERT_EQ(pool.state(j), JobState::Planned);
    // Both idle at 0: the GPU finishes 2 s of CPU work in 0.1 s (+ 5 ms over PCIe); without
    // the rule, the device whose timeline ends first (a tie, the lower id: the CPU).
    EXPECT_EQ(s.activity(pool.activity(j)).device, completion_aware ? c.gpudev[0] : c.cpu[0]);
  }
}

TEST(Rayline, RemoteRaysWaitUntilWorthATransferUnlessTheNodeIsIdle) {
  for (const bool batching : {true, false}) {
    // Horizon 0.5 s, min_remote_bytes 256 KiB, hold 0.1 s (rule 4), or without rule 4.
    EightBlocksWarm w(false, 1, 5, 8, rayline_options(0.5, batching ? 0u : *rayline_rules_off("batching")));
    const Cluster& c = w.c;
    JobPool& pool = w.pool;
    Schedule& s = w.s;
    const std::vector<BlockId>& scene = w.scene;
    RaylineScheduler& rs = w.rs;
    // Node 1 busy for 0.2 s with rays already there (6.4 MB at 32 MB/s).
    const JobId local = ray_job(pool, s, scene[7], 6'400'000, c.ram[1], "local");
    rs.plan(0, pool, s);
    ASSERT_EQ(pool.state(local), JobState::Planned);
    ASSERT_EQ(rs.ownership().owner[0][7], 1);
    // A few remote rays for node 1's block wait while node 1 is busy; a large queue goes.
    const JobId few = ray_job(pool, s, scene[6], 64'000, c.ram[0], "few", 0.01);
    const JobId many = ray_job(pool, s, scene[5], 2 * kMB, c.ram[0], "many", 0.01);  // over 1 MiB
    rs.plan(0.01, pool, s);
    EXPECT_EQ(pool.state(many), JobState::Planned);
    if (!batching) {
      EXPECT_EQ(pool.state(few), JobState::Planned) << "without rule 4, at once";
      continue;
    }
    EXPECT_EQ(pool.state(few), JobState::Queued);
    rs.plan(0.05, pool, s);
    EXPECT_EQ(pool.state(few), JobState::Queued) << "held for 0.1 s";
    rs.plan(0.12, pool, s);
    EXPECT_EQ(pool.state(few), JobState::Planned) << "held no longer than 0.1 s";
  }
}

TEST(Rayline, RunsEveryJobOnceWithValidSchedulesOnRandomInstances) {
  for (int seed = 0; seed < 30; ++seed) {
    std::mt19937 rng(5200 + seed);
    const bool split = seed % 3 != 0;  // scenes too large for one node, or small ones
    Cluster c(1 + seed % 4, seed % 2 == 0, {125e6, 12.5e6, 125e6, 1e6});
    JobPool pool;
    Schedule s(c.g, pool);
    std::vector<BlockId> scene;
    for (int b = 0; b < 3 + seed % 8; ++b)
      scene.push_back(scene_block(pool, s, c,
                                  split ? std::uniform_int_distribution<Bytes>(1500 * kMB, 3000 * kMB)(rng)
                                        : std::uniform_int_distribution<Bytes>(10 * kMB, 400 * kMB)(rng),
                                  std::to_string(b)));
    for (int q = 0; q < 5 + seed % 20; ++q) {
      const MemId at = c.ram[std::uniform_int_distribution<std::size_t>(0, c.ram.size() - 1)(rng)];
      ray_job(pool, s, scene[std::uniform_int_distribution<std::size_t>(0, scene.size() - 1)(rng)],
              std::uniform_int_distribution<Bytes>(10'000, 40 * kMB)(rng), at, std::to_string(q),
              std::uniform_real_distribution<Time>(0, 0.05)(rng));
    }
    RaylineScheduler rs;
    ExactExecutor ex(s);
    StaticWorkload wl;
    RuntimeLoop loop(rs, ex, wl, pool, s);
    ASSERT_FALSE(loop.run().stalled) << seed;
    for (std::size_t j = 0; j < pool.job_count(); ++j) EXPECT_EQ(pool.state(static_cast<JobId>(j)), JobState::Done) << seed;
    const auto chk = rayline::testing::check_schedule(s, pool);
    for (const auto& e : chk.errors) ADD_FAILURE() << "seed " << seed << ": " << e;
  }
}

// Rule 6 re-projects the timelines only now and then. A device whose work ended earlier than
// planned (reality won) is free at once all the same: a job queued then is planned, not
// left waiting for a projection (which, with nothing else running, never comes).
TEST(Rayline, ADeviceThatFinishedEarlyIsFreeBeforeTheNextProjection) {
  const Cluster c(1, false);
  JobPool pool;
  Schedule s(c.g, pool);
  const BlockId sc = scene_block(pool, s, c, 100 * kMB, "0");
  s.put_initial(sc, c.ram[0], 0, false);
  const JobId first = ray_job(pool, s, sc, 32 * kMB, c.ram[0], "first");  // 1 s at 32 MB/s
  RaylineScheduler rs;
  rs.plan(0, pool, s);
  ASSERT_EQ(pool.state(first), JobState::Planned);
  const ActivityId a = pool.activity(first);
  ASSERT_GT(s.device_timeline(c.cpu[0]).busy_until, 0.9);
  s.on_started(a, 0);
  s.on_finished(a, 0.001);  // far sooner than planned
  pool.mark_done(first);
  const JobId next = ray_job(pool, s, sc, 1 * kMB, c.ram[0], "next", 0.001);
  rs.plan(0.002, pool, s);  // within a hundredth of the look-ahead of the last projection
  EXPECT_EQ(pool.state(next), JobState::Planned);
}

TEST(RaylineRules, NamesSwitchOffTheirRule) {
  EXPECT_EQ(rayline_rules_off(""), 0u);
  EXPECT_EQ(rayline_rules_off("ownership,batching"), 1u | 8u);
  EXPECT_EQ(rayline_rules_off("no-waiting,,completion"), 16u | 4u);
  EXPECT_EQ(rayline_rules_off("job-size"), 32u);
  EXPECT_FALSE(rayline_rules_off("ownership,teleport").has_value());
  const RaylineOptions all = rayline_options(0.5, 0);
  EXPECT_TRUE(all.ownership && all.image_split && all.completion_aware && all.no_waiting);
  EXPECT_GT(all.min_remote_bytes, 0u);
  const RaylineOptions none = rayline_options(0.25, *rayline_rules_off("ownership,image-split,completion,batching,no-waiting"));
  EXPECT_FALSE(none.ownership || none.image_split || none.completion_aware || none.no_waiting);
  EXPECT_EQ(none.min_remote_bytes, 0u);
  EXPECT_EQ(none.horizon, 0.25);
  // Rule 8 is off unless switched on, and switching it off wins.
  const unsigned generation = rayline_rule_bit("generation");
  EXPECT_EQ(rayline_rules_off("generation"), generation);
  EXPECT_FALSE(all.owner_generation);
  EXPECT_TRUE(rayline_options(0.5, 0, generation).owner_generation);
  EXPECT_FALSE(rayline_options(0.5, generation, generation).owner_generation);
  // So is rule 4's hold of every small ray job, which rule 8 switches on too.
  const unsigned hold = rayline_rule_bit("hold");
  EXPECT_EQ(all.min_local_bytes, 0u);
  EXPECT_GT(rayline_options(0.5, 0, hold).min_local_bytes, 0u);
  EXPECT_GT(rayline_options(0.5, 0, generation).min_local_bytes, 0u);
  EXPECT_EQ(rayline_options(0.5, *rayline_rules_off("batching"), hold).min_local_bytes, 0u);
}

// Rule 8: the node that makes a wave's camera rays entering a block is that block's owner in
// the wave's group (here one group: the two nodes split the eight blocks), whatever the wave;
// the rule needs ownership and the image split, and names nothing for a block that is not
// scene data.
TEST(RaylineRules, GenerationNamesTheOwnerOfTheEntryBlock) {
  const unsigned generation = rayline_rule_bit("generation");
  EightQueuesOnNode0 r{rayline_options(0.5, 0, generation)};
  ASSERT_FALSE(r.stalled);
  ASSERT_TRUE(r.rs.places_ray_origins());
  const Ownership& o = r.rs.ownership();
  ASSERT_EQ(o.groups.size(), 1u);
  ASSERT_FALSE(o.replicated());
  std::set<NodeId> owners;
  for (const std::uint64_t wave : {0ull, 1ull, 977ull})
    for (BlockId b = 0; b < 8; ++b) {  // the scene blocks are the first eight
      EXPECT_EQ(r.rs.ray_origin(wave, b, r.pool, r.s), o.owner[0][static_cast<std::size_t>(b)]) << "block " << b;
      owners.insert(r.rs.ray_origin(wave, b, r.pool, r.s));
    }
  EXPECT_EQ(owners.size(), 2u) << "both nodes own blocks";
  EXPECT_EQ(r.rs.ray_origin(0, 8, r.pool, r.s), kNone) << "a ray queue is no entry block";
  for (const char* rule : {"ownership", "image-split", "generation"}) {
    RaylineScheduler off{rayline_options(0.5, *rayline_rules_off(rule), generation)};
    EXPECT_FALSE(off.places_ray_origins()) << rule;
    EXPECT_EQ(off.ray_origin(0, 0, r.pool, r.s), kNone) << rule;
  }
}

// Rule 7: the cap of a job type is what its fastest device traces in the given seconds, by
// Eq. 2's rate on the queue (paper node A: the GPU's 640 MB/s of RayQueue, 2 560 MB/s of
// hit records for Shade, 896 MB/s of shadow rays; the CPU threads' rates are slower).
TEST(RaylineRules, JobSizeCapIsWhatTheFastestDeviceTracesInItsSeconds) {
  const DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/paper-A.json");
  const std::vector<Bytes> caps = device_sized_job_caps(g, 0.125);
  ASSERT_EQ(caps.size(), g.job_types.size());
  const auto cap = [&](const char* type) { return static_cast<double>(caps.at(static_cast<std::size_t>(g.job_type(type)))); };
  EXPECT_NEAR(cap("RayIntersect"), 0.125 * 640e6, 1.0);
  EXPECT_NEAR(cap("ShadowIntersect"), 0.125 * 896e6, 1.0);
  EXPECT_NEAR(cap("Shade"), 0.125 * 2560e6, 1.0);
  for (const Bytes c : device_sized_job_caps(g, 0)) EXPECT_EQ(c, 0u) << "no seconds, no cap";
  EXPECT_EQ(rayline_options(0.5, 0).job_seconds, 0.125);
  EXPECT_EQ(rayline_options(0.5, *rayline_rules_off("job-size")).job_seconds, 0.0);
}

TEST(RaylineRules, WithoutOwnershipRaysStayAndTheSceneComesToThem) {
  EightQueuesOnNode0 r{rayline_options(0.5, *rayline_rules_off("ownership"))};
  ASSERT_FALSE(r.stalled);
  for (std::size_t i = 0; i < r.s.activity_count(); ++i) {
    const Activity& a = r.s.activity(static_cast<ActivityId>(i));
    if (a.kind == ActivityKind::Exec) {
      EXPECT_EQ(r.c.g.computes[a.device].node, 0) << "job " << a.job << " runs where its rays are";
    } else {
      const Channel& ch = r.c.g.channels[a.channel];
      EXPECT_EQ(r.c.g.memories[ch.from].node, r.c.g.memories[ch.to].node) << "nothing crosses the LAN";
    }
  }
  r.expect_done_and_valid();
}

// Rule 4 on every ray job ("hold", or rule 8): a small one (here on its own node) waits for
// the hold (0.1 s) while its node runs something, even with a device idle (node 0's GPU);
// by default, or without rule 4, it goes at once.
TEST(RaylineRules, HoldKeepsSmallLocalJobsWhileTheirNodeRuns) {
  const unsigned hold = rayline_rule_bit("hold"), gen = rayline_rule_bit("generation");
  for (const auto& [off, on, held] : {std::tuple{0u, 0u, false}, {0u, hold, true}, {0u, gen, true},
                                      {rayline_rule_bit("batching"), hold | gen, false}}) {
    EightBlocksWarm w(true, 0, 0, 2, rayline_options(0.5, off, on));
    const Cluster& c = w.c;
    JobPool& pool = w.pool;
    Schedule& s = w.s;
    const std::vector<BlockId>& scene = w.scene;
    RaylineScheduler& rs = w.rs;
    const JobId busy = ray_job(pool, s, scene[0], 6'400'000, c.ram[0], "busy");  // 0.2 s on a CPU
    rs.plan(0, pool, s);
    ASSERT_EQ(pool.state(busy), JobState::Planned);
    ASSERT_EQ(rs.ownership().owner[0][1], 0) << "node 0 owns block 1: its rays are local";
    const JobId few = ray_job(pool, s, scene[1], 64'000, c.ram[0], "few", 0.01);
    rs.plan(0.01, pool, s);
    if (!held) {
      EXPECT_EQ(pool.state(few), JobState::Planned) << "without the hold, at once";
      continue;
    }
    EXPECT_EQ(pool.state(few), JobState::Queued) << "under 1 MiB: held";
    rs.plan(0.05, pool, s);
    EXPECT_EQ(pool.state(few), JobState::Queued) << "held for 0.1 s";
    rs.plan(0.12, pool, s);
    EXPECT_EQ(pool.state(few), JobState::Planned) << "held no longer than 0.1 s";
  }
}

// ... but only while its own node runs something: a node whose devices are all idle takes
// a small job at once, however busy the other nodes are (a frame's last rays are not held
// hop after hop while the devices that would trace them wait).
TEST(RaylineRules, HoldKeepsNothingOnANodeWithEveryDeviceIdle) {
  EightBlocksWarm w(true, 0, 0, 2, rayline_options(0.5, 0, rayline_rule_bit("hold")));
  // With a GPU each node holds the scene: two groups of one node, rays stay on their node.
  const JobId busy = ray_job(w.pool, w.s, w.scene[7], 6'400'000, w.c.ram[1], "busy");
  w.rs.plan(0, w.pool, w.s);
  ASSERT_EQ(w.pool.state(busy), JobState::Planned);
  ASSERT_EQ(w.c.g.computes[w.s.activity(w.pool.activity(busy)).device].node, 1) << "node 0 stays idle";
  const JobId few = ray_job(w.pool, w.s, w.scene[1], 64'000, w.c.ram[0], "few", 0.01);
  w.rs.plan(0.01, w.pool, w.s);
  EXPECT_EQ(w.pool.state(few), JobState::Planned) << "node 0 idle: at once";
}

// Rule 9 (room): a wave of camera rays (a job that declares the rays it will write) is made
// only where three times the rays on the memory device, the wave included, leave room for
// the largest scene block; a wave that would crowd it out waits. Without the rule, both go.
TEST(RaylineRules, RoomKeepsWavesThatWouldCrowdOutTheScene) {
  for (const bool room : {true, false}) {
    Cluster c(1, false);  // one node: 8 GiB of RAM, one CPU thread
    JobPool pool;
    Schedule s(c.g, pool);
    (void)scene_block(pool, s, c, 1500 * kMB, "0");
    const BlockId parked = rayline::testing::add_block(pool, "parked", DataKind::RayQueue, 2000 * kMB);
    s.put_initial(parked, c.ram[0], 0, false);  // 2 GB of rays no job reads yet
    auto wave = [&](Bytes bytes, const std::string& tag) {
      const BlockId req = rayline::testing::add_block(pool, "request" + tag, DataKind::Generic, 1000);
      s.put_initial(req, c.ram[0], 0, false);
      Job j;
      j.name = "wave" + tag;
      j.type = 0;
      j.inputs = {req};
      j.expected_output_bytes = bytes;
      return pool.add_job(std::move(j));
    };
    // 8.59 GB - 3 x (2.0 + 0.1) GB = 2.29 GB >= 1.5 GB; with 0.4 GB more, 1.09 GB < 1.5 GB.
    const JobId small = wave(100 * kMB, "0");
    const JobId large = wave(400 * kMB, "1");
    RaylineScheduler rs(rayline_options(0.5, room ? 0u : rayline_rule_bit("room")));
    rs.plan(0, pool, s);
    EXPECT_EQ(pool.state(small), JobState::Planned) << "room " << room;
    EXPECT_EQ(pool.state(large), room ? JobState::Queued : JobState::Planned) << "room " << room;
  }
}

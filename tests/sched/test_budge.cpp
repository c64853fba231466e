// Budge et al. 2009 as parametrised in sched/policy/budge.hpp: each rule pinned on a hand-built
// state, and the schedule invariants on random instances.
#include <gtest/gtest.h>

#include <random>

#include "dcg_fixture.hpp"
#include "sched/policy/budge.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/runtime/runtime_loop.hpp"

using namespace rayline;

namespace {
using Nodes = rayline::testing::Cluster;

// A new scene block on `scene_at` (its only copy) and a ray queue on `rays_at`.
struct SceneAndRays {
  BlockId scene, rays;
};
SceneAndRays scene_and_rays(JobPool& pool, Schedule& s, const std::string& tag, Bytes scene, MemId scene_at, Bytes rays,
                            MemId rays_at) {
  const BlockId sc = rayline::testing::add_block(pool, "scene" + tag, DataKind::SceneData, scene);
  s.put_initial(sc, scene_at);
  const BlockId rq = rayline::testing::add_block(pool, "rays" + tag, DataKind::RayQueue, rays);
  s.put_initial(rq, rays_at);
  return {sc, rq};
}


}  // namespace

TEST(Budge, ResidentDataFirstThenLargestQueue) {
  for (bool resident_first : {true, false}) {
    Nodes t(1, false);
    JobPool pool;
    Schedule s(t.g, pool);
    const BlockId hot = rayline::testing::add_block(pool, "hot", DataKind::SceneData, 100'000'000);
    const BlockId cold = rayline::testing::add_block(pool, "cold", DataKind::SceneData, 100'000'000);
    s.put_initial(hot, t.disk[0]);
    s.put_initial(hot, t.ram[0], 0, false);  // already cached in RAM
    s.put_initial(cold, t.disk[0]);
    const BlockId small = rayline::testing::add_block(pool, "small", DataKind::RayQueue, 1'000'000);
    const BlockId large = rayline::testing::add_block(pool, "large", DataKind::RayQueue, 30'000'000);
    s.put_initial(small, t.ram[0]);
    s.put_initial(large, t.ram[0]);
    const JobId a = rayline::testing::add_job(pool, "resident-small", 0, {hot, small});
    const JobId b = rayline::testing::add_job(pool, "cold-large", 0, {cold, large});
    BudgeScheduler bs({.resident_first = resident_first});
    bs.plan(0, pool, s);
    EXPECT_EQ(pool.state(resident_first ? a : b), JobState::Planned);
    EXPECT_EQ(pool.state(resident_first ? b : a), JobState::Queued) << "one job per idle device";
  }
}

// A queued job that grew by merges (Sec. 5.1: a ray queue arriving for the same block joins
// it) ranks by its rays now, not by what it held when the policy first saw it.
TEST(Budge, AJobThatGrewByMergesRanksByItsRaysNow) {
  Nodes t(1, false);
  JobPool pool;
  Schedule s(t.g, pool);
  const BlockId sc = rayline::testing::add_block(pool, "scene", DataKind::SceneData, 100'000'000);
  s.put_initial(sc, t.disk[0]);
  s.put_initial(sc, t.ram[0], 0, false);
  auto queue = [&](const std::string& name, Bytes bytes) {
    const BlockId q = rayline::testing::add_block(pool, name, DataKind::RayQueue, bytes);
    s.put_initial(q, t.ram[0]);
    return q;
  };
  const JobId large = rayline::testing::add_job(pool, "large", 0, {sc, queue("large", 30'000'000)});
  const JobId grows = rayline::testing::add_job(pool, "grows", 0, {sc, queue("grows", 1'000'000)});
  const JobId middle = rayline::testing::add_job(pool, "middle", 0, {sc, queue("middle", 20'000'000)});
  BudgeScheduler bs;
  bs.plan(0, pool, s);
  ASSERT_EQ(pool.state(large), JobState::Planned);
  ASSERT_EQ(pool.state(grows), JobState::Queued);
  pool.add_input(grows, queue("merged", 40'000'000));  // now 41 MB against 20 MB
  const ActivityId a = pool.activity(large);
  s.on_started(a, 0);
  s.on_finished(a, s.activity(a).end);
  pool.mark_done(large);
  bs.plan(s.activity(a).end, pool, s);
  EXPECT_EQ(pool.state(grows), JobState::Planned);
  EXPECT_EQ(pool.state(middle), JobState::Queued);
}

TEST(Budge, RaysNeverLeaveTheirNodeAndSceneComesFromTheNodesOwnDisk) {
  Nodes t(2, false);
  JobPool pool;
  Schedule s(t.g, pool);
  const BlockId sc = rayline::testing::add_block(pool, "scene", DataKind::SceneData, 100'000'000);
  s.put_initial(sc, t.disk[0]);
  s.put_initial(sc, t.disk[1]);
  for (int q = 0; q < 4; ++q) {
    const BlockId rq = rayline::testing::add_block(pool, "rays" + std::to_string(q), DataKind::RayQueue, 8'000'000);
    s.put_initial(rq, t.ram[1]);  // all rays belong to node 1's image region
    rayline::testing::add_job(pool, "j" + std::to_string(q), 0, {sc, rq});
  }
  BudgeScheduler bs;
  ExactExecutor ex(s);
  StaticWorkload wl;
  RuntimeLoop loop(bs, ex, wl, pool, s);
  ASSERT_FALSE(loop.run().stalled);
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.kind == ActivityKind::Exec) {
      EXPECT_EQ(a.device, t.cpu[1]);
    } else {
      // Only node 1's own SATA link: nothing crosses the LAN.
      EXPECT_EQ(t.g.memories[t.g.channels[a.channel].from].node, 1);
      EXPECT_EQ(t.g.memories[t.g.channels[a.channel].to].node, 1);
    }
  }
  EXPECT_NE(bs.describe().find("resident_first=1"), std::string::npos);
}

TEST(Budge, IntersectionGoesToTheGpuWhenTheBlockFits) {
  Nodes t(1, true);
  JobPool pool;
  Schedule s(t.g, pool);
  const auto [sc, rq] = scene_and_rays(pool, s, "", 200'000'000, t.disk[0], 8'000'000, t.ram[0]);
  const JobId j = rayline::testing::add_job(pool, "j", 0, {sc, rq});
  BudgeScheduler bs;
  bs.plan(0, pool, s);
  ASSERT_EQ(pool.state(j), JobState::Planned);
  EXPECT_EQ(s.activity(pool.activity(j)).device, t.gpudev[0]);
  // Without the rule the CPU (device 0, first in order) may take it.
  JobPool pool2;
  Schedule s2(t.g, pool2);
  const BlockId sc2 = rayline::testing::add_block(pool2, "scene", DataKind::SceneData, 200'000'000);
  s2.put_initial(sc2, t.disk[0]);
  const BlockId rq2 = rayline::testing::add_block(pool2, "rays", DataKind::RayQueue, 8'000'000);
  s2.put_initial(rq2, t.ram[0]);
  const JobId j2 = rayline::testing::add_job(pool2, "j", 0, {sc2, rq2});
  BudgeScheduler bs2({.gpu_preferred = false});
  bs2.plan(0, pool2, s2);
  ASSERT_EQ(pool2.state(j2), JobState::Planned);
}

TEST(Budge, RunsEveryJobOnceWithValidSchedulesOnRandomInstances) {
  for (int seed = 0; seed < 30; ++seed) {
    std::mt19937 rng(900 + seed);
    Nodes t(1 + seed % 3, seed % 2 == 0);
    JobPool pool;
    Schedule s(t.g, pool);
    std::vector<BlockId> scene;
    for (int b = 0; b < 2 + seed % 5; ++b) {
      scene.push_back(rayline::testing::add_block(pool, "scene" + std::to_string(b), DataKind::SceneData,
                            std::uniform_int_distribution<Bytes>(10'000'000, 400'000'000)(rng)));
      for (MemId d : t.disk) s.put_initial(scene.back(), d);
    }
    for (int q = 0; q < 5 + seed % 15; ++q) {
      const BlockId rq = rayline::testing::add_block(pool, "rays" + std::to_string(q), DataKind::RayQueue,
                               std::uniform_int_distribution<Bytes>(1'000'000, 40'000'000)(rng));
      s.put_initial(rq, t.ram[std::uniform_int_distribution<std::size_t>(0, t.ram.size() - 1)(rng)]);
      rayline::testing::add_job(pool, "j" + std::to_string(q), 0, {scene[std::uniform_int_distribution<std::size_t>(0, scene.size() - 1)(rng)], rq});
    }
    BudgeScheduler bs;
    ExactExecutor ex(s);
    StaticWorkload wl;
    RuntimeLoop loop(bs, ex, wl, pool, s);
    ASSERT_FALSE(loop.run().stalled) << seed;
    for (std::size_t j = 0; j < pool.job_count(); ++j) EXPECT_EQ(pool.state(static_cast<JobId>(j)), JobState::Done);
    const auto c = rayline::testing::check_schedule(s, pool);
    for (const auto& e : c.errors) ADD_FAILURE() << "seed " << seed << ": " << e;
  }
}

// Image-space decomposition over nodes: GenerateRays jobs on a client's request (only
// Generic inputs, all on node 0's RAM) are spread over nodes in proportion to their peak
// ray throughput (default) or equally, each job to a fixed node; the rays they make then
// stay there.
TEST(Budge, ImageSplitSpreadsRayGenerationOverNodesByThroughput) {
  rayline::testing::DcgBuilder b;
  std::vector<MemId> ram;
  for (int i = 0; i < 2; ++i) {
    const NodeId nd = b.node("n" + std::to_string(i));
    ram.push_back(b.mem("n" + std::to_string(i) + ".ram", Bytes(8) << 30, MemoryKind::Host, nd));
    for (int c = 0; c < (i == 0 ? 1 : 3); ++c) b.dev("n" + std::to_string(i) + ".cpu" + std::to_string(c), ram.back());
  }
  b.full_duplex(ram[0], ram[1], 125e6, 1e-4);
  const JobTypeId gen = b.g.add_job_type("GenerateRays");
  b.timing(0, DataKind::RayQueue, 32e6, 5e-6);  // RayIntersect: node 1 has 3x node 0's throughput
  b.timing(gen, DataKind::Generic, 1e9, 5e-6);
  const DeviceGraph g = b.build();
  int by_tp[2] = {0, 0}, equal[2] = {0, 0};
  for (JobId j = 0; j < 4000; ++j) {
    const NodeId a = budge_image_node(j, g, true), e = budge_image_node(j, g, false);
    ASSERT_TRUE(a == 0 || a == 1) << a;
    ASSERT_TRUE(e == 0 || e == 1);
    ++by_tp[a];
    ++equal[e];
    EXPECT_EQ(a, budge_image_node(j, g, true)) << "a job's node is fixed";
  }
  EXPECT_NEAR(by_tp[1] / 4000.0, 0.75, 0.03);
  EXPECT_NEAR(equal[1] / 4000.0, 0.5, 0.03);

  // The scheduler follows it: each GenerateRays job runs on the node its id maps to, the
  // request crossing the LAN once.
  JobPool pool;
  Schedule s(g, pool);
  std::vector<JobId> jobs;
  for (int q = 0; q < 8; ++q) {
    const BlockId req = rayline::testing::add_block(pool, "request" + std::to_string(q), DataKind::Generic, 1000);
    s.put_initial(req, ram[0]);
    jobs.push_back(rayline::testing::add_job(pool, "gen" + std::to_string(q), gen, {req}));
  }
  BudgeScheduler bs;
  ExactExecutor ex(s);
  StaticWorkload wl;
  RuntimeLoop loop(bs, ex, wl, pool, s);
  ASSERT_FALSE(loop.run().stalled);
  for (JobId j : jobs)
    EXPECT_EQ(g.computes[s.activity(pool.activity(j)).device].node, budge_image_node(j, g, true)) << j;
  EXPECT_NE(bs.describe().find("image_split=by-throughput"), std::string::npos);
}

namespace {
// An engine bounded by the run's end that runs its clock on to it once nothing is in
// flight, as SimGrid does: the loop never sees the executor return early.
class ClockRunsOn final : public Executor {
 public:
  explicit ClockRunsOn(const Schedule& s) : inner_(s) {}
  void dispatch(ActivityId id, const Activity& a) override { inner_.dispatch(id, a); }
  Time now() const override { return std::max(inner_.now(), end_); }
  void run(const Sink& sink, Time until) override {
    inner_.run(sink, until);
    end_ = until;
  }
  void wake_at(Time t) override { inner_.wake_at(t); }
  void halt(const std::vector<DeviceId>& c, const std::vector<ChannelId>& ch, std::vector<ExecutorEvent>& e) override {
    inner_.halt(c, ch, e);
  }
  void abort(const std::vector<ActivityId>& ids) override { inner_.abort(ids); }

 private:
  ExactExecutor inner_;
  Time end_ = 0;
};
}  // namespace

// Budge plans for idle devices only. When the last activity in flight ends with a job
// still queued that nothing will ever take (its 64 GiB scene block fits no memory a
// device works from), the loop must find out then, not let the engine idle to the end.
TEST(Budge, AJobNothingTakesIsAStallEvenWhenTheEngineRunsItsClockOn) {
  Nodes t(1, false);
  JobPool pool;
  Schedule s(t.g, pool);
  const auto runs = scene_and_rays(pool, s, "", 1'000'000, t.disk[0], 1'000'000, t.ram[0]);
  rayline::testing::add_job(pool, "runs", 0, {runs.scene, runs.rays});
  const auto never = scene_and_rays(pool, s, "-huge", Bytes(64) << 30, t.disk[0], 1'000'000, t.ram[0]);  // > 8 GiB RAM
  rayline::testing::add_job(pool, "never", 0, {never.scene, never.rays});
  BudgeScheduler bs;
  ClockRunsOn ex(s);
  StaticWorkload wl;
  RuntimeLoop loop(bs, ex, wl, pool, s);
  const RunStats st = loop.run(100.0);
  EXPECT_TRUE(st.stalled);
  EXPECT_EQ(pool.queued_count(), 1u);
}

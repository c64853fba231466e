// LoadAnyOnce (the paper's Navratil 2014 baseline, GraviT rule): the decision rule pinned
// on hand-built states, bulk-synchronous rounds, whole domains to one rank, scene data
// only from storage or the rank's own node, and the schedule invariants.
#include <gtest/gtest.h>

#include <random>

#include "dcg_fixture.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/policy/load_any_once.hpp"
#include "sched/runtime/runtime_loop.hpp"

using namespace rayline;

TEST(LoadAnyOnce, HighestDemandDomainsGoToRanksZeroOneTwoRestIdle) {
  const std::vector<std::uint64_t> demand = {5, 50, 0, 30, 40};
  EXPECT_EQ(load_any_once_assign(demand, 3), (std::vector<std::int32_t>{1, 4, 3}));
  // More ranks than demanded domains: the extra ranks idle; zero demand is never loaded.
  EXPECT_EQ(load_any_once_assign(demand, 6), (std::vector<std::int32_t>{1, 4, 3, 0, kNone, kNone}));
  // Equal demand: higher domain id first, as GraviT's (count << 7) + id key popped last.
  EXPECT_EQ(load_any_once_assign({10, 10, 10}, 2), (std::vector<std::int32_t>{2, 1}));
  // Demands beyond 2^24 rays (where GraviT's int key overflows) still sort correctly.
  EXPECT_EQ(load_any_once_assign({std::uint64_t(1) << 40, std::uint64_t(1) << 30}, 1), (std::vector<std::int32_t>{0}));
  EXPECT_TRUE(load_any_once_assign({}, 4) == std::vector<std::int32_t>(4, kNone));
}

// Ranks that cannot run every domain (a client node's thread that only composes): each
// domain, in demand order, goes to the first free rank that can run it; with every rank
// able, the plain rule's map; a domain no free rank can run waits.
TEST(LoadAnyOnce, ADomainSkipsRanksThatCannotRunIt) {
  const std::vector<std::uint64_t> demand = {5, 50, 0, 30, 40};
  const auto all = [](int, std::int32_t) { return true; };
  for (int ranks = 0; ranks <= 6; ++ranks)
    EXPECT_EQ(load_any_once_assign(demand, ranks, all), load_any_once_assign(demand, ranks)) << ranks;
  // Rank 0 runs only domain 0 (the lowest demand): the larger domains go to the ranks after
  // it, and domain 0, last in the order, to rank 0, before domain 3 that no free rank runs.
  const auto client = [](int r, std::int32_t d) { return r != 0 || d == 0; };
  EXPECT_EQ(load_any_once_assign(demand, 3, client), (std::vector<std::int32_t>{0, 1, 4}));
  EXPECT_EQ(load_any_once_assign(demand, 5, client), (std::vector<std::int32_t>{0, 1, 4, 3, kNone}));
  // Nobody runs domain 1: it is given to no rank.
  const auto no_one = [](int, std::int32_t d) { return d != 1; };
  EXPECT_EQ(load_any_once_assign(demand, 3, no_one), (std::vector<std::int32_t>{4, 3, 0}));
  // Property: every assignment is to a rank that can run it, each domain at most once.
  std::mt19937 rng(5);
  for (int t = 0; t < 200; ++t) {
    std::vector<std::uint64_t> dm(std::uniform_int_distribution<int>(0, 8)(rng));
    for (auto& x : dm) x = std::uniform_int_distribution<int>(0, 4)(rng);
    const int ranks = std::uniform_int_distribution<int>(0, 8)(rng);
    const std::uint32_t mask_seed = static_cast<std::uint32_t>(rng());
    const auto can = [&](int r, std::int32_t d) { return ((mask_seed >> ((r * 3 + d) % 31)) & 1u) != 0; };
    const auto map = load_any_once_assign(dm, ranks, can);
    std::vector<int> seen(dm.size(), 0);
    for (int r = 0; r < ranks; ++r) {
      const std::int32_t d = map[static_cast<std::size_t>(r)];
      if (d == kNone) continue;
      EXPECT_TRUE(can(r, d));
      EXPECT_GT(dm[static_cast<std::size_t>(d)], 0u);
      EXPECT_EQ(++seen[static_cast<std::size_t>(d)], 1);
    }
  }
}

namespace {
struct TwoNodes {
  DeviceGraph g;
  MemId disk0, ram0, disk1, ram1;
  TwoNodes() {
    rayline::testing::DcgBuilder b;
    const NodeId n0 = b.node("n0"), n1 = b.node("n1");
    disk0 = b.mem("n0.disk", Bytes(1) << 40, MemoryKind::Disk, n0);
    ram0 = b.mem("n0.ram", Bytes(8) << 30, MemoryKind::Host, n0);
    disk1 = b.mem("n1.disk", Bytes(1) << 40, MemoryKind::Disk, n1);
    ram1 = b.mem("n1.ram", Bytes(8) << 30, MemoryKind::Host, n1);
    b.half_duplex(disk0, ram0, 150e6, 0.01);
    b.half_duplex(disk1, ram1, 150e6, 0.01);
    b.full_duplex(ram0, ram1, 1e9, 1e-4);  // a fast LAN: GMB would copy from the peer's RAM
    for (int c = 0; c < 2; ++c) b.dev("n0.cpu" + std::to_string(c), ram0);
    for (int c = 0; c < 2; ++c) b.dev("n1.cpu" + std::to_string(c), ram1);
    b.timing(0, DataKind::RayQueue, 32e6, 5e-6);
    g = b.build();
  }
};

}  // namespace

TEST(LoadAnyOnce, RoundsAreBulkSynchronousAndDomainsAreDrainedByOneRank) {
  TwoNodes t;
  JobPool pool;
  Schedule s(t.g, pool);
  std::vector<BlockId> scene;
  for (int b = 0; b < 3; ++b) {
    scene.push_back(rayline::testing::add_block(pool, "scene" + std::to_string(b), DataKind::SceneData, 200'000'000));
    s.put_initial(scene.back(), t.disk0);
    s.put_initial(scene.back(), t.disk1);
  }
  // Domain demand: scene0 has 3 queues, scene1 2, scene2 1 (32 MB each = 500 k rays).
  const int per[3] = {3, 2, 1};
  for (int b = 0; b < 3; ++b)
    for (int q = 0; q < per[b]; ++q) {
      const BlockId rq = rayline::testing::add_block(pool, "rays" + std::to_string(b) + "_" + std::to_string(q), DataKind::RayQueue, 32'000'000);
      s.put_initial(rq, q % 2 ? t.ram1 : t.ram0);
      Job j;
      j.name = "j" + std::to_string(b) + "_" + std::to_string(q);
      j.type = 0;
      j.inputs = {scene[static_cast<std::size_t>(b)], rq};
      pool.add_job(std::move(j));
    }
  LoadAnyOnceScheduler lao;
  lao.plan(0, pool, s);
  EXPECT_EQ(pool.queued_count(), 0u);
  // Ranks 0, 1, 2 got scene0, scene1, scene2; rank 3 idles.
  for (std::size_t j = 0; j < pool.job_count(); ++j) {
    const Activity& a = s.activity(pool.activity(static_cast<JobId>(j)));
    const std::string& name = pool.job(static_cast<JobId>(j)).name;
    EXPECT_EQ(a.device, name[1] - '0') << name;
  }
  EXPECT_TRUE(s.device_timeline(3).items.empty());
  // Scene data only from the rank's own storage (every node has a full copy): every
  // SceneData transfer is disk -> RAM on one node, none crosses the LAN.
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.kind != ActivityKind::Transfer || pool.block(a.block).kind != DataKind::SceneData) continue;
    const Channel& c = t.g.channels[a.channel];
    EXPECT_EQ(t.g.memories[c.from].kind, MemoryKind::Disk) << c.name;
    EXPECT_EQ(t.g.memories[c.from].node, t.g.memories[c.to].node) << c.name;
  }
  // A new job while the round runs: nothing is planned until every rank is idle.
  const BlockId rq = rayline::testing::add_block(pool, "late", DataKind::RayQueue, 32'000'000);
  s.put_initial(rq, t.ram0);
  Job late;
  late.name = "late";
  late.type = 0;
  late.inputs = {scene[0], rq};
  pool.add_job(std::move(late));
  const PlanStats ps = lao.plan(0.5, pool, s);
  EXPECT_EQ(ps.execs, 0);
  EXPECT_EQ(pool.queued_count(), 1u);
}

TEST(LoadAnyOnce, RunsEveryJobOnceWithValidSchedulesOnRandomInstances) {
  for (int seed = 0; seed < 30; ++seed) {
    std::mt19937 rng(300 + seed);
    TwoNodes t;
    JobPool pool;
    Schedule s(t.g, pool);
    std::vector<BlockId> scene;
    const int nb = 2 + seed % 6;
    for (int b = 0; b < nb; ++b) {
      scene.push_back(rayline::testing::add_block(pool, "scene" + std::to_string(b), DataKind::SceneData,
                            std::uniform_int_distribution<Bytes>(10'000'000, 300'000'000)(rng)));
      s.put_initial(scene.back(), t.disk0);
      s.put_initial(scene.back(), t.disk1);
    }
    const int nj = 5 + seed % 20;
    for (int q = 0; q < nj; ++q) {
      const BlockId rq = rayline::testing::add_block(pool, "rays" + std::to_string(q), DataKind::RayQueue,
                               std::uniform_int_distribution<Bytes>(1'000'000, 64'000'000)(rng));
      s.put_initial(rq, q % 2 ? t.ram1 : t.ram0);
      Job j;
      j.name = "j" + std::to_string(q);
      j.type = 0;
      j.inputs = {scene[std::uniform_int_distribution<std::size_t>(0, scene.size() - 1)(rng)], rq};
      pool.add_job(std::move(j));
    }
    LoadAnyOnceScheduler lao;
    ExactExecutor ex(s);
    StaticWorkload wl;
    RuntimeLoop loop(lao, ex, wl, pool, s);
    loop.record_triggers = seed % 2 == 0;
    const RunStats st = loop.run();
    ASSERT_FALSE(st.stalled) << seed;
    for (std::size_t j = 0; j < pool.job_count(); ++j) EXPECT_EQ(pool.state(static_cast<JobId>(j)), JobState::Done);
    const auto c = rayline::testing::check_schedule(s, pool);
    for (const auto& e : c.errors) ADD_FAILURE() << "seed " << seed << ": " << e;
    EXPECT_GE(lao.rounds(), 1u);
    // What each plan answered (RuntimeLoop::triggers, the renderer's loop-latency samples):
    // a finished E-job, ended by the time the plan committed the activity, with its own
    // duration; the first plan (before anything ran) answered none; later rounds did.
    const auto& tr = loop.triggers();
    if (!loop.record_triggers) {
      EXPECT_TRUE(tr.empty());
      continue;
    }
    EXPECT_LE(tr.size(), s.activity_count());
    std::size_t answered = 0;
    for (std::size_t id = 0; id < tr.size(); ++id) {
      if (tr[id].end < 0) continue;
      ++answered;
      const Activity& a = s.activity(static_cast<ActivityId>(id));
      EXPECT_LE(tr[id].end, a.start + 1e-12) << "seed " << seed << ": activity " << id;
      bool found = false;
      for (std::size_t e = 0; e < s.activity_count() && !found; ++e) {
        const Activity& x = s.activity(static_cast<ActivityId>(e));
        found = x.kind == ActivityKind::Exec && x.end == tr[id].end && x.end - x.start == tr[id].exec_seconds;
      }
      EXPECT_TRUE(found) << "seed " << seed << ": activity " << id << " answered no E-job that ended at " << tr[id].end;
    }
    for (std::size_t id = 0; id < tr.size(); ++id) {
      if (s.activity(static_cast<ActivityId>(id)).planned_start == 0) {
        EXPECT_LT(tr[id].end, 0) << "seed " << seed;
      }
    }
    if (lao.rounds() > 1) {
      EXPECT_GT(answered, 0u) << "seed " << seed;
    }
  }
}

// Jobs with explicit `after` dependencies (static job sets): a job whose predecessor is not
// planned yet is no demand in this round (GraviT counts rays that exist); it runs in a later
// round, after its predecessor, instead of being committed before it.
TEST(LoadAnyOnce, AJobThatMustFollowAnotherWaitsForALaterRound) {
  TwoNodes t;
  JobPool pool;
  Schedule s(t.g, pool);
  std::vector<BlockId> scene;
  for (int b = 0; b < 2; ++b) {
    scene.push_back(rayline::testing::add_block(pool, "scene" + std::to_string(b), DataKind::SceneData, 100'000'000));
    s.put_initial(scene.back(), t.disk0);
    s.put_initial(scene.back(), t.disk1);
  }
  auto rays = [&](const std::string& n, Bytes bytes) {
    const BlockId rq = rayline::testing::add_block(pool, n, DataKind::RayQueue, bytes);
    s.put_initial(rq, t.ram0);
    return rq;
  };
  // `second` has the larger queue (it would get rank 0) but must follow `first`.
  const JobId first = rayline::testing::add_job(pool, "first", 0, {scene[0], rays("r0", 1'000'000)});
  Job j;
  j.name = "second";
  j.type = 0;
  j.inputs = {scene[1], rays("r1", 50'000'000)};
  j.after = {first};
  const JobId second = pool.add_job(std::move(j));
  LoadAnyOnceScheduler lao;
  EXPECT_NO_THROW(lao.plan(0, pool, s));
  EXPECT_EQ(pool.state(first), JobState::Planned);
  EXPECT_EQ(pool.state(second), JobState::Queued);
  EXPECT_EQ(s.activity(pool.activity(first)).device, 0) << "the only demanded domain goes to rank 0";
  // The whole run finishes with `second` after `first`.
  ExactExecutor ex(s);
  StaticWorkload wl;
  RuntimeLoop loop(lao, ex, wl, pool, s);
  ASSERT_FALSE(loop.run().stalled);
  ASSERT_EQ(pool.state(second), JobState::Done);
  EXPECT_GE(s.activity(pool.activity(second)).start, s.activity(pool.activity(first)).end);
  EXPECT_EQ(lao.rounds(), 2u);
  const auto c = rayline::testing::check_schedule(s, pool);
  for (const auto& e : c.errors) ADD_FAILURE() << e;
}

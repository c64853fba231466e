// The SimGrid executor driven by the runtime loop and GMB (issue 3): with no contention a
// plan runs exactly as predicted; with contention (channels sharing a NIC) reality departs,
// every job still completes, and the gap is measured. Each TEST is its own process.
#include <gtest/gtest.h>

#include "../sched/dcg_fixture.hpp"
#include "sched/gmb_scheduler.hpp"
#include "sched/runtime_loop.hpp"
#include "sim/sim_executor.hpp"

using namespace rayline;
using rayline::testing::DcgBuilder;

namespace {
constexpr double MB = 1e6;

// Node 0 holds three scene blocks in RAM; nodes 1-3 each have one CPU and need one block.
// All LAN channels out of node 0 share its NIC-out resource.
struct Star {
  DeviceGraph g;
  JobPool pool;
  std::vector<std::pair<BlockId, MemId>> init;
  Star() {
    DcgBuilder b;
    std::vector<MemId> ram;
    for (int i = 0; i < 4; ++i) {
      const NodeId n = b.node("n" + std::to_string(i));
      ram.push_back(b.mem("n" + std::to_string(i) + ".ram", Bytes(8) << 30, MemoryKind::Host, n));
      if (i > 0) b.dev("n" + std::to_string(i) + ".cpu", ram.back());
    }
    const ResourceId out0 = b.resource("n0.nic.out", 100 * MB);
    for (int i = 1; i < 4; ++i) {
      const ResourceId in = b.resource("n" + std::to_string(i) + ".nic.in", 100 * MB);
      b.channel(ram[0], ram[static_cast<std::size_t>(i)], 100 * MB, 1e-4, {out0, in});
    }
    b.timing(0, DataKind::SceneData, 100 * MB, 1e-5);
    g = b.build();
    for (int i = 1; i < 4; ++i) {
      DataBlock blk;
      blk.name = "scene" + std::to_string(i);
      blk.kind = DataKind::SceneData;
      blk.bytes = static_cast<Bytes>(100 * MB);
      const BlockId id = pool.add_block(blk);
      init.emplace_back(id, ram[0]);
      Job j;
      j.name = "j" + std::to_string(i);
      j.type = 0;
      j.inputs = {id};
      pool.add_job(std::move(j));
    }
  }
};

Time planned_makespan(const Schedule& s) {
  Time t = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i) t = std::max(t, s.activity(static_cast<ActivityId>(i)).planned_end);
  return t;
}
}  // namespace

TEST(SimExecutor, NoContentionReproducesThePredictedMakespanExactly) {
  Star st;
  Schedule s(st.g, st.pool);
  for (auto [b, m] : st.init) s.put_initial(b, m);
  sim::SgPlatform platform(st.g);
  GmbScheduler gmb({.horizon = 1e9});
  sim::SimExecutor ex(platform, s, {.order_per_resource = true, .exec_factor = {}});
  StaticWorkload wl;
  RuntimeLoop loop(gmb, ex, wl, st.pool, s);
  const RunStats r = loop.run();
  EXPECT_FALSE(r.stalled);
  for (JobId j = 0; j < 3; ++j) EXPECT_EQ(st.pool.state(j), JobState::Done);
  const Time predicted = planned_makespan(s);
  // Three 1 s transfers serialised on n0's NIC, then 1 s of work after the last: 4 s.
  EXPECT_NEAR(predicted, 3 * (1e-4 + 1.0) + 1e-5 + 1.0, 1e-9);
  EXPECT_NEAR(r.makespan, predicted, 1e-9 * predicted);
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    EXPECT_NEAR(a.end, a.planned_end, 1e-9) << i;
  }
}

TEST(SimExecutor, ContentionOnASharedNicMakesRealityDifferAndEveryJobStillCompletes) {
  Star st;
  Schedule s(st.g, st.pool);
  for (auto [b, m] : st.init) s.put_initial(b, m);
  sim::SgPlatform platform(st.g);
  GmbScheduler gmb({.horizon = 1e9});
  sim::SimExecutor ex(platform, s);  // per-channel order: the three transfers share the NIC
  StaticWorkload wl;
  RuntimeLoop loop(gmb, ex, wl, st.pool, s);
  const RunStats r = loop.run();
  EXPECT_FALSE(r.stalled);
  for (JobId j = 0; j < 3; ++j) EXPECT_EQ(st.pool.state(j), JobState::Done);
  // Run together at a third of the NIC each, all three blocks arrive at ~3 s instead of
  // 1, 2, 3 s: the first two jobs start later than planned, the makespan is the same.
  int late = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.kind == ActivityKind::Transfer) {
      EXPECT_NEAR(a.end, 1e-4 + 3.0, 1e-6);
    }
    if (a.kind == ActivityKind::Exec && a.end > a.planned_end + 1e-6) ++late;
  }
  EXPECT_EQ(late, 2);
  // In parallel the latencies overlap too: 0.2 ms earlier than the serialised plan.
  EXPECT_NEAR(r.makespan, 1e-4 + 3.0 + 1e-5 + 1.0, 1e-6);
  EXPECT_NEAR(planned_makespan(s) - r.makespan, 2e-4, 1e-9);
}

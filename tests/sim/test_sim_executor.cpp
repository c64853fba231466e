// The SimGrid executor driven by the runtime loop and GMB: with no contention a
// plan runs exactly as predicted; with contention (channels sharing a NIC) reality departs,
// every job still completes, and the gap is measured. Each TEST is its own process.
#include <gtest/gtest.h>

#include <memory>

#include "../sched/dcg_fixture.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/runtime/runtime_loop.hpp"
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

// GMB (horizon beyond the whole job set) planning the job set once, run on SimGrid under
// the runtime loop with executor options `xo`.
struct SimRun {
  Schedule s;
  std::unique_ptr<sim::SgPlatform> platform;
  RunStats r;
  SimRun(const DeviceGraph& g, JobPool& pool, const std::vector<std::pair<BlockId, MemId>>& init,
         const sim::SimExecutorOptions& xo, const sim::SgOptions& so = {})
      : s(g, pool) {
    for (auto [b, m] : init) s.put_initial(b, m);
    platform = std::make_unique<sim::SgPlatform>(g, so);
    GmbScheduler gmb({.horizon = 1e9});
    sim::SimExecutor ex(*platform, s, xo);
    StaticWorkload wl;
    RuntimeLoop loop(gmb, ex, wl, pool, s);
    r = loop.run();
  }
};
}  // namespace

TEST(SimExecutor, NoContentionReproducesThePredictedMakespanExactly) {
  Star st;
  SimRun run(st.g, st.pool, st.init, {.transfer_order = sim::TransferOrder::Resource, .exec_factor = {}});
  const Schedule& s = run.s;
  const RunStats& r = run.r;
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
  SimRun run(st.g, st.pool, st.init, {});  // per-channel order: the three transfers share the NIC
  const Schedule& s = run.s;
  const RunStats& r = run.r;
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

TEST(SimExecutor, ExclusiveOrderRunsSharedNicTransfersOneAtATimeAsPlanned) {
  // The three transfers are all ready at once: one at a time they end at 1, 2 and 3 s,
  // exactly as the plan serialised them on n0's NIC.
  Star st;
  SimRun run(st.g, st.pool, st.init, {.transfer_order = sim::TransferOrder::Exclusive, .exec_factor = {}});
  const Schedule& s = run.s;
  const RunStats& r = run.r;
  EXPECT_FALSE(r.stalled);
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    EXPECT_NEAR(a.start, a.planned_start, 1e-9) << i;
    EXPECT_NEAR(a.end, a.planned_end, 1e-9) << i;
  }
  EXPECT_NEAR(r.makespan, planned_makespan(s), 1e-9 * r.makespan);
}

namespace {
// Head-of-line blocking on a shared NIC. n0's CPU runs P (1 s planned) producing w (50 MB);
// Q on n1 needs w, R on n2 needs s1 (300 MB), both from n0 through n0's NIC-out. GMB plans
// w's transfer first (1.0-1.5 s) and s1's after it (1.5-4.5 s). In reality P takes 2 s.
struct HeadOfLine {
  DeviceGraph g;
  JobPool pool;
  std::vector<std::pair<BlockId, MemId>> init;
  JobId p = kNone, q = kNone, r = kNone;
  BlockId w = kNone, s1 = kNone;
  HeadOfLine() {
    DcgBuilder b;
    std::vector<MemId> ram;
    for (int i = 0; i < 3; ++i) {
      const NodeId n = b.node("n" + std::to_string(i));
      ram.push_back(b.mem("n" + std::to_string(i) + ".ram", Bytes(8) << 30, MemoryKind::Host, n));
      b.dev("n" + std::to_string(i) + ".cpu", ram.back());
    }
    const ResourceId out0 = b.resource("n0.nic.out", 100 * MB);
    for (int i = 1; i < 3; ++i) {
      const ResourceId in = b.resource("n" + std::to_string(i) + ".nic.in", 100 * MB);
      b.channel(ram[0], ram[static_cast<std::size_t>(i)], 100 * MB, 1e-4, {out0, in});
    }
    b.timing(0, DataKind::SceneData, 100 * MB);  // P: 100 MB of scene, 1 s
    b.timing(1, DataKind::RayQueue, 100 * MB);   // Q: 50 MB of rays, 0.5 s
    b.timing(1, DataKind::SceneData, 300 * MB);  // R: 300 MB of scene, 1 s
    b.g.timing.at(0, 1).supported = false;       // P only on n0, Q and R only on n1, n2
    b.g.timing.at(1, 0).supported = false;
    b.g.timing.at(2, 0).supported = false;
    g = b.build();
    const BlockId s0 = rayline::testing::add_block(pool, "s0", DataKind::SceneData, Bytes(100 * MB));
    s1 = rayline::testing::add_block(pool, "s1", DataKind::SceneData, Bytes(300 * MB));
    w = rayline::testing::add_block(pool, "w", DataKind::RayQueue, Bytes(50 * MB));
    init = {{s0, ram[0]}, {s1, ram[0]}};
    p = rayline::testing::add_job(pool, "P", 0, {s0}, {w});
    q = rayline::testing::add_job(pool, "Q", 1, {w});
    r = rayline::testing::add_job(pool, "R", 1, {s1});
  }
};

struct HolTimes {
  Time w_start = 0, w_end = 0, s1_start = 0, s1_end = 0, makespan = 0;
};
HolTimes run_head_of_line(sim::TransferOrder order) {
  HeadOfLine h;
  const JobId p = h.p;
  sim::SimExecutorOptions xo;
  xo.transfer_order = order;
  xo.exec_factor = [p](ActivityId, const Activity& a) { return a.job == p ? 2.0 : 1.0; };
  SimRun run(h.g, h.pool, h.init, xo);
  const Schedule& s = run.s;
  const RunStats& st = run.r;
  EXPECT_FALSE(st.stalled);
  HolTimes out;
  out.makespan = st.makespan;
  int transfers = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.kind != ActivityKind::Transfer) continue;
    ++transfers;
    if (a.block == h.w) {
      EXPECT_NEAR(a.planned_start, 1.0, 1e-3);  // the plan this test is about
      out.w_start = a.start, out.w_end = a.end;
    } else if (a.block == h.s1) {
      EXPECT_NEAR(a.planned_start, 1.5, 1e-3);
      out.s1_start = a.start, out.s1_end = a.end;
    }
  }
  EXPECT_EQ(transfers, 2);
  return out;
}
}  // namespace

// (One SgPlatform per process: one order per TEST.)
TEST(SimExecutor, ResourceOrderKeepsAReadyTransferBehindOneWaitingForItsData) {
  // s1 waits behind w, which waits for P (2 s): w 2.0-2.5, s1 2.5-5.5.
  const HolTimes res = run_head_of_line(sim::TransferOrder::Resource);
  EXPECT_NEAR(res.w_start, 2.0, 1e-3);
  EXPECT_NEAR(res.s1_start, res.w_end, 1e-9);
  EXPECT_NEAR(res.s1_end, 5.5, 1e-3);
  EXPECT_NEAR(res.makespan, 6.5, 1e-3);  // R's 1 s after s1
}

TEST(SimExecutor, ExclusiveOrderLetsAReadyTransferOvertakeAndThenWaitsForTheNic) {
  // s1 overtakes (ready, NIC free) 0-3 s; w, ready at 2 s, waits for the NIC: 3.0-3.5.
  const HolTimes exc = run_head_of_line(sim::TransferOrder::Exclusive);
  EXPECT_NEAR(exc.s1_start, 0.0, 1e-9);
  EXPECT_NEAR(exc.s1_end, 3.0, 1e-3);
  EXPECT_NEAR(exc.w_start, exc.s1_end, 1e-9);
  EXPECT_NEAR(exc.w_end, 3.5, 1e-3);
  EXPECT_NEAR(exc.makespan, 4.0, 1e-3);  // max(R 3-4, Q 3.5-4)
}

TEST(SimExecutor, ChannelOrderRunsBothAtOnceSharingTheNic) {
  // From 2 s both share the NIC, 50 MB/s each: w's 50 MB end at ~3 s, s1's last 100 MB at ~3.5 s.
  const HolTimes ch = run_head_of_line(sim::TransferOrder::Channel);
  EXPECT_NEAR(ch.s1_start, 0.0, 1e-9);
  EXPECT_NEAR(ch.w_start, 2.0, 1e-3);
  EXPECT_NEAR(ch.w_end, 3.0, 1e-2);
  EXPECT_NEAR(ch.s1_end, 3.5, 1e-2);
}

namespace {
// A chain: each job is made only when the one before it finished (as rays spawn rays), so
// the runtime loop dispatches every job but the first in answer to a finished E-job.
class ChainWorkload final : public Workload {
 public:
  ChainWorkload(BlockId block, int n) : block_(block), n_(n) {}
  void start(Time now, JobPool& pool, Schedule&) override { add(now, pool); }
  void on_job_finished(JobId, Time now, JobPool& pool, Schedule&) override {
    ++done_;
    if (made_ < n_) add(now, pool);
  }
  bool finished() const override { return done_ == n_; }

 private:
  void add(Time now, JobPool& pool) {
    Job j;
    j.name = "c" + std::to_string(made_++);
    j.type = 0;
    j.inputs = {block_};
    j.created = now;
    pool.add_job(std::move(j));
  }
  BlockId block_;
  int n_, made_ = 0, done_ = 0;
};
}  // namespace

// The control loop (DeviceGraph::loop): a job dispatched in answer to a finished one starts
// that job's end + per_job + per_exec_second x its duration later; without the model, at once.
// (One SimGrid platform per process: one TEST each.)
namespace {
// Three chained 1 s jobs on one CPU thread (ChainWorkload), run under GMB with the given
// control loop and, if set, a hold on the first dispatch.
struct ChainRun {
  DeviceGraph g;
  JobPool pool;
  std::unique_ptr<Schedule> s;
  RunStats r;
  int holds_asked = 0;
  ChainRun(ControlLoop loop, Time hold) {
    DcgBuilder b;
    const NodeId n = b.node("n0");
    const MemId ram = b.mem("n0.ram", Bytes(8) << 30, MemoryKind::Host, n);
    b.dev("n0.cpu", ram);
    b.timing(0, DataKind::SceneData, 100 * MB, 1e-5);
    g = b.build();
    g.loop = loop;
    DataBlock blk;
    blk.name = "scene";
    blk.kind = DataKind::SceneData;
    blk.bytes = static_cast<Bytes>(100 * MB);
    const BlockId id = pool.add_block(blk);
    s = std::make_unique<Schedule>(g, pool);
    s->put_initial(id, ram);
    sim::SgPlatform platform(g);
    GmbScheduler gmb({.horizon = 1e9});
    sim::SimExecutor ex(platform, *s, {});
    if (hold > 0) ex.hold_first_dispatch([this, hold] { ++holds_asked; return hold; });
    ChainWorkload wl(id, 3);
    RuntimeLoop rl(gmb, ex, wl, pool, *s);
    r = rl.run();
  }
};

void expect_chain_gaps(bool modelled) {
  const ChainRun run(modelled ? ControlLoop{0.5, 0.25} : ControlLoop{}, 0);
  const Schedule& s = *run.s;
  ASSERT_FALSE(run.r.stalled);
  const Time d = 1.0 + 1e-5;
  const Time gap = modelled ? 0.5 + 0.25 * d : 0.0;
  EXPECT_NEAR(run.r.makespan, 3 * d + 2 * gap, 1e-9);
  ASSERT_EQ(s.activity_count(), 3u);
  for (std::size_t i = 1; i < s.activity_count(); ++i)
    EXPECT_NEAR(s.activity(ActivityId(i)).start, s.activity(ActivityId(i - 1)).end + gap, 1e-9) << i;
}
}  // namespace

TEST(SimExecutor, WithoutAControlLoopTheNextJobStartsAtOnce) { expect_chain_gaps(false); }
TEST(SimExecutor, ControlLoopDelaysWhatIsDispatchedAfterAFinishedJob) { expect_chain_gaps(true); }

// ControlLoop::wake: a load that waits after its dispatch for an E-job (here the one whose
// block it evicts: RAM holds one block) starts that E-job's end + wake; the first load, ready
// when dispatched, and everything else start at once.
namespace {
void expect_wake(Time wake) {
  DcgBuilder b;
  const NodeId n = b.node("n0");
  const MemId disk = b.mem("n0.disk", Bytes(1) << 40, MemoryKind::Disk, n);
  const MemId ram = b.mem("n0.ram", static_cast<Bytes>(100 * MB), MemoryKind::Host, n);
  b.dev("n0.cpu", ram);
  b.half_duplex(disk, ram, 100 * MB, 0);
  b.timing(0, DataKind::SceneData, 100 * MB, 0);
  DeviceGraph g = b.build();
  g.loop.wake = wake;
  JobPool pool;
  std::vector<std::pair<BlockId, MemId>> init;
  for (int k = 0; k < 2; ++k) {
    const BlockId id = rayline::testing::add_block(pool, "scene" + std::to_string(k), DataKind::SceneData,
                                                   static_cast<Bytes>(100 * MB));
    init.push_back({id, disk});
    rayline::testing::add_job(pool, "j" + std::to_string(k), 0, {id});
  }
  SimRun run(g, pool, init, {});
  ASSERT_FALSE(run.r.stalled);
  // load 0 [0, 1], E-job 0 [1, 2], load 1 after E-job 0 (+ wake), E-job 1 after it.
  const Schedule& s = run.s;
  ASSERT_EQ(s.activity_count(), 4u);
  EXPECT_NEAR(s.activity(0).start, 0.0, 1e-9);
  EXPECT_NEAR(s.activity(1).start, 1.0, 1e-9);
  EXPECT_EQ(s.activity(2).kind, ActivityKind::Transfer);
  EXPECT_NEAR(s.activity(2).start, 2.0 + wake, 1e-9);
  EXPECT_NEAR(s.activity(3).start, 3.0 + wake, 1e-9);
  EXPECT_NEAR(run.r.makespan, 4.0 + wake, 1e-9);
}
}  // namespace

// SimExecutor::hold_first_dispatch (ControlLoop::per_camera_ray): what the first plan
// dispatches starts at the hold, asked once at that dispatch; the chain's later jobs follow
// their predecessors at once (no loop latency modelled), so the makespan moves by the hold.
namespace {
void expect_first_hold(Time hold) {
  const ChainRun run(ControlLoop{}, hold);
  const Schedule& s = *run.s;
  ASSERT_FALSE(run.r.stalled);
  const Time d = 1.0 + 1e-5;
  EXPECT_EQ(run.holds_asked, hold > 0 ? 1 : 0);
  ASSERT_EQ(s.activity_count(), 3u);
  EXPECT_NEAR(s.activity(0).start, hold, 1e-9);
  for (std::size_t i = 1; i < s.activity_count(); ++i)
    EXPECT_NEAR(s.activity(ActivityId(i)).start, s.activity(ActivityId(i - 1)).end, 1e-9) << i;
  EXPECT_NEAR(run.r.makespan, hold + 3 * d, 1e-9);
}
}  // namespace

// ControlLoop::pickup: three jobs known at the start on one thread are all planned and
// dispatched at 0, so the second and third were dispatched before their predecessor ended
// and start `pickup` after it; the first, on an idle thread, starts at once.
namespace {
void expect_pickup(Time pickup) {
  DcgBuilder b;
  const NodeId n = b.node("n0");
  const MemId ram = b.mem("n0.ram", Bytes(8) << 30, MemoryKind::Host, n);
  b.dev("n0.cpu", ram);
  b.timing(0, DataKind::SceneData, 100 * MB, 0);
  DeviceGraph g = b.build();
  g.loop.pickup = pickup;
  JobPool pool;
  const BlockId id = rayline::testing::add_block(pool, "scene", DataKind::SceneData, static_cast<Bytes>(100 * MB));
  for (int k = 0; k < 3; ++k) rayline::testing::add_job(pool, "j" + std::to_string(k), 0, {id});
  SimRun run(g, pool, {{id, ram}}, {});
  ASSERT_FALSE(run.r.stalled);
  const Schedule& s = run.s;
  ASSERT_EQ(s.activity_count(), 3u);
  EXPECT_NEAR(s.activity(0).start, 0.0, 1e-9);
  for (std::size_t i = 1; i < 3; ++i)
    EXPECT_NEAR(s.activity(ActivityId(i)).start, s.activity(ActivityId(i - 1)).end + pickup, 1e-9) << i;
  EXPECT_NEAR(run.r.makespan, 3.0 + 2 * pickup, 1e-9);
}
}  // namespace

TEST(SimExecutor, WithoutPickupAPreDispatchedJobStartsAtItsPredecessorsEnd) { expect_pickup(0); }
TEST(SimExecutor, PickupDelaysAJobDispatchedBeforeItsThreadRanDry) { expect_pickup(0.125); }

TEST(SimExecutor, WithoutAHoldTheFirstPlanStartsAtZero) { expect_first_hold(0); }
TEST(SimExecutor, TheFirstPlanWaitsForTheLoopsStartUp) { expect_first_hold(0.375); }

TEST(SimExecutor, WithoutWakeALoadWaitingForAnEJobStartsAtItsEnd) { expect_wake(0); }
TEST(SimExecutor, WakeDelaysALoadThatWaitedForAnEJob) { expect_wake(0.25); }

// Channel::cpu_contention: while k of the node's 2 CPU threads run E-jobs, a load moves its
// bytes at bandwidth / (1 + c k / 2). k blocks start in RAM, each with a 1 s E-job that
// starts at once; a 1 s load (at full bandwidth) of a block from the disk starts at 0 too.
// It moves 1 / f of its bytes in the first second (f = 1 + c k / 2), the rest at full speed
// once the E-jobs have ended: 2 - 1 / f seconds.
namespace {
void expect_contention(double c, int busy, double e = 0) {
  DcgBuilder b;
  const NodeId n = b.node("n0");
  const MemId disk = b.mem("n0.disk", Bytes(1) << 40, MemoryKind::Disk, n);
  const MemId ram = b.mem("n0.ram", static_cast<Bytes>(300 * MB), MemoryKind::Host, n);
  b.dev("n0.cpu0", ram);
  b.dev("n0.cpu1", ram);
  b.half_duplex(disk, ram, 100 * MB, 0);
  b.timing(0, DataKind::SceneData, 100 * MB, 0);
  DeviceGraph g = b.build();
  for (Channel& ch : g.channels) {
    ch.cpu_contention = c;
    ch.exec_contention = e;
  }
  JobPool pool;
  std::vector<std::pair<BlockId, MemId>> init;
  for (int k = 0; k <= busy; ++k) {
    const BlockId id = rayline::testing::add_block(pool, "scene" + std::to_string(k), DataKind::SceneData,
                                                   static_cast<Bytes>(100 * MB));
    init.push_back({id, k < busy ? ram : disk});
    rayline::testing::add_job(pool, "j" + std::to_string(k), 0, {id});
  }
  sim::SgOptions so;
  so.exclusive_execs = true;  // as rayline simulate runs (execs as timers that a slowdown can stretch)
  SimRun run(g, pool, init, {}, so);
  ASSERT_FALSE(run.r.stalled);
  const Schedule& s = run.s;
  int loads = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.kind != ActivityKind::Transfer) continue;
    ++loads;
    EXPECT_NEAR(a.start, 0.0, 1e-9);
    const double f = 1 + c * busy / 2.0;
    EXPECT_NEAR(a.end - a.start, 2 - 1 / f, 1e-6) << "c " << c << ", busy " << busy;
    EXPECT_NEAR(a.planned_end - a.planned_start, 1.0, 1e-9);  // the plan's Eq. 1 ignores it
  }
  EXPECT_EQ(loads, 1);
  // With exec_contention e (and c = 0): the resident blocks' E-jobs run 1 + e times slower
  // while the load runs, [0, 1], and the rest at full speed: they end at 2 - 1 / (1 + e).
  for (std::size_t i = 0; i < s.activity_count() && e > 0; ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.kind == ActivityKind::Exec && a.start == 0) {
      EXPECT_NEAR(a.end, 2 - 1 / (1 + e), 1e-6);
    }
  }
}
}  // namespace

// (One SgPlatform per process: one run per TEST.)
TEST(SimExecutor, ALoadBesideIdleThreadsTakesEq1) { expect_contention(1.5, 0); }
TEST(SimExecutor, ALoadBesideOneBusyThreadOfTwoSharesTheCores) { expect_contention(1.0, 1); }
TEST(SimExecutor, ALoadBesideTwoBusyThreadsSharesTheCores) { expect_contention(2.0, 2); }
TEST(SimExecutor, ThreadsBesideALoadRunTheirJobsSlower) { expect_contention(0, 2, 0.5); }

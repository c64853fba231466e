// Schedule::cancel (Sec. 5.2: a predicted job that did not happen is "discarded with its
// T-jobs"): what is withdrawn, what is kept because others count on it, and that the
// channel time it held goes to the activities behind it.
#include <gtest/gtest.h>

#include "dcg_fixture.hpp"
#include "sched/runtime/exact_executor.hpp"

using namespace rayline;
using namespace rayline::testing;

namespace {
constexpr Bytes MB = 1000000;

// disk -> ram0 -> ram1 (1 MB/s each), one CPU thread on each RAM.
struct Chain {
  DcgBuilder b;
  MemId disk, ram0, ram1;
  ChannelId c_disk, c_lan;
  DeviceId cpu0, cpu1;
  DeviceGraph g;
  Chain() {
    disk = b.mem("disk", Bytes(1) << 40, MemoryKind::Disk);
    ram0 = b.mem("ram0", 100 * MB);
    ram1 = b.mem("ram1", 100 * MB);
    c_disk = b.channel(disk, ram0, 1e6);
    c_lan = b.channel(ram0, ram1, 1e6);
    cpu0 = b.dev("cpu0", ram0);
    cpu1 = b.dev("cpu1", ram1);
    b.timing(0, DataKind::SceneData, 1e9);
    g = b.build();
  }
};

// Runs every activity with ExactExecutor, reporting to the schedule as the runtime loop does.
std::vector<ExecutorEvent> run_all(Schedule& s) {
  ExactExecutor ex(s);
  for (std::size_t i = 0; i < s.activity_count(); ++i) ex.dispatch(static_cast<ActivityId>(i), s.activity(static_cast<ActivityId>(i)));
  std::vector<ExecutorEvent> all, ev;
  while (ex.advance(ev)) {
    for (const ExecutorEvent& e : ev) {
      if (e.type == ExecutorEvent::Type::Started) s.on_started(e.activity, e.time);
      else s.on_finished(e.activity, e.time);
      all.push_back(e);
    }
    ev.clear();
  }
  return all;
}

// The independent invariant checker of dcg_fixture.hpp, every violation reported.
void expect_valid(const Schedule& s, const JobPool& pool) {
  for (const auto& e : check_schedule(s, pool).errors) ADD_FAILURE() << e;
}

Time finished_at(const std::vector<ExecutorEvent>& ev, ActivityId a) {
  for (const ExecutorEvent& e : ev)
    if (e.activity == a && e.type == ExecutorEvent::Type::Finished) return e.time;
  return kNever;
}
}  // namespace

TEST(ScheduleCancel, WithdrawnPrefetchGivesItsChannelTimeToTheNextTransfer) {
  Chain c;
  JobPool pool;
  const BlockId a = add_block(pool, "sceneA", DataKind::SceneData, MB);
  const BlockId bb = add_block(pool, "sceneB", DataKind::SceneData, MB);
  const JobId ja = add_job(pool, "jA", 0, {a});
  const JobId jb = add_job(pool, "jB", 0, {bb});
  Schedule s(c.g, pool);
  s.put_initial(a, c.disk);
  s.put_initial(bb, c.disk);
  const ActivityId ta = s.commit_transfer(a, c.c_disk, ja, 0, s.admission(c.ram0, MB, {}));
  const ActivityId ea = s.commit_exec(ja, c.cpu0, 0, {});
  pool.mark_planned(ja, ea);
  const ActivityId tb = s.commit_transfer(bb, c.c_disk, jb, 0, s.admission(c.ram0, MB, {}));
  const ActivityId eb = s.commit_exec(jb, c.cpu0, 0, {});
  pool.mark_planned(jb, eb);
  ASSERT_DOUBLE_EQ(s.activity(tb).start, 1.0);  // behind A's 1 s on the disk channel

  const Schedule::CancelCount n = s.cancel_job(ja);
  EXPECT_EQ(n.execs, 1);
  EXPECT_EQ(n.transfers, 1);
  EXPECT_EQ(n.kept_transfers, 0);
  EXPECT_EQ(n.bytes, MB);
  EXPECT_TRUE(s.activity(ta).cancelled);
  EXPECT_TRUE(s.activity(ea).cancelled);
  EXPECT_EQ(s.copy_at(a, c.ram0), nullptr) << "the withdrawn copy leaves the plan at once";
  EXPECT_EQ(s.used(c.ram0), 2 * MB) << "its bytes stay reserved until the withdrawn T-job ends";
  EXPECT_FALSE(s.cancel(ta)) << "cancelling twice changes nothing";

  s.reproject(0);
  EXPECT_DOUBLE_EQ(s.activity(tb).start, 0.0) << "the channel time goes to the next transfer";
  EXPECT_DOUBLE_EQ(s.activity(eb).end, 1.0 + s.activity(eb).duration);

  const auto ev = run_all(s);
  EXPECT_DOUBLE_EQ(finished_at(ev, ta), 0.0);
  EXPECT_DOUBLE_EQ(finished_at(ev, ea), 0.0);
  EXPECT_DOUBLE_EQ(finished_at(ev, tb), 1.0);
  EXPECT_EQ(s.used(c.ram0), MB) << "only sceneB remains once the withdrawn T-job ended";
  EXPECT_EQ(s.unfinished(), 0u);
  expect_valid(s, pool);
}

TEST(ScheduleCancel, KeepsATransferWhoseCopyAnotherJobReads) {
  Chain c;
  JobPool pool;
  const BlockId a = add_block(pool, "sceneA", DataKind::SceneData, MB);
  const JobId j1 = add_job(pool, "predicted", 0, {a});
  const JobId j2 = add_job(pool, "real", 0, {a});
  Schedule s(c.g, pool);
  s.put_initial(a, c.disk);
  const ActivityId t = s.commit_transfer(a, c.c_disk, j1, 0, s.admission(c.ram0, MB, {}));
  const ActivityId e1 = s.commit_exec(j1, c.cpu0, 0, {});
  pool.mark_planned(j1, e1);
  const ActivityId e2 = s.commit_exec(j2, c.cpu0, 0, {});  // shares the prefetched copy
  pool.mark_planned(j2, e2);
  const Schedule::CancelCount n = s.cancel_job(j1);
  EXPECT_EQ(n.execs, 1);
  EXPECT_EQ(n.transfers, 0);
  EXPECT_EQ(n.kept_transfers, 1);
  EXPECT_FALSE(s.activity(t).cancelled);
  ASSERT_NE(s.copy_at(a, c.ram0), nullptr);
  EXPECT_EQ(s.copy_at(a, c.ram0)->users, ActivityList{e2});
  run_all(s);
  expect_valid(s, pool);
}

TEST(ScheduleCancel, WithdrawsAMultiHopChainLastHopFirst) {
  Chain c;
  JobPool pool;
  const BlockId a = add_block(pool, "sceneA", DataKind::SceneData, MB);
  const JobId j = add_job(pool, "far", 0, {a});
  Schedule s(c.g, pool);
  s.put_initial(a, c.disk);
  const ActivityId h1 = s.commit_transfer(a, c.c_disk, j, 0, s.admission(c.ram0, MB, {}));
  const ActivityId h2 = s.commit_transfer(a, c.c_lan, j, 0, s.admission(c.ram1, MB, {}));
  const ActivityId e = s.commit_exec(j, c.cpu1, 0, {});
  pool.mark_planned(j, e);
  EXPECT_FALSE(s.cancel(h1)) << "the first hop's copy feeds the second";
  const Schedule::CancelCount n = s.cancel_job(j);
  EXPECT_EQ(n.transfers, 2);
  EXPECT_TRUE(s.activity(h1).cancelled);
  EXPECT_TRUE(s.activity(h2).cancelled);
  EXPECT_EQ(s.copy_at(a, c.ram0), nullptr);
  EXPECT_EQ(s.copy_at(a, c.ram1), nullptr);
  run_all(s);
  EXPECT_EQ(s.used(c.ram0), 0u);
  EXPECT_EQ(s.used(c.ram1), 0u);
  expect_valid(s, pool);
}

TEST(ScheduleCancel, RefusesStartedActivitiesAndRayQueueMoves) {
  Chain c;
  JobPool pool;
  const BlockId a = add_block(pool, "sceneA", DataKind::SceneData, MB);
  const BlockId q = add_block(pool, "rays", DataKind::RayQueue, MB);
  ASSERT_TRUE(pool.block(q).consumed);
  const JobId j = add_job(pool, "j", 0, {a, q});
  Schedule s(c.g, pool);
  s.put_initial(a, c.ram0, 0, false);
  s.put_initial(q, c.ram0, 0, false);
  s.put_initial(a, c.ram1, 0, false);
  const ActivityId mv = s.commit_transfer(q, c.c_lan, j, 0, s.admission(c.ram1, MB, {}));
  EXPECT_FALSE(s.cancel(mv)) << "a moved ray queue is unique data";
  const ActivityId e = s.commit_exec(j, c.cpu1, 0, {});
  pool.mark_planned(j, e);
  EXPECT_FALSE(s.cancel(e)) << "it consumes a ray queue";
  const BlockId b2 = add_block(pool, "sceneB", DataKind::SceneData, MB);
  const JobId j2 = add_job(pool, "j2", 0, {b2});
  s.put_initial(b2, c.disk);
  const ActivityId t2 = s.commit_transfer(b2, c.c_disk, j2, 0, s.admission(c.ram0, MB, {}));
  s.on_started(t2, 0);
  EXPECT_FALSE(s.cancel(t2)) << "already running";
  EXPECT_FALSE(s.activity(t2).cancelled);
}

// Schedule::node_epoch (what Rayline's policy reads to skip nodes whose plan would be the
// same): it moves on a node exactly when something there changes. Two nodes, a disk and a
// RAM on the first, a RAM on the second, a LAN channel between the RAMs.
TEST(ScheduleNodeEpoch, MovesOnlyOnTheNodesAChangeTouches) {
  DcgBuilder b;
  const NodeId n0 = b.node("n0"), n1 = b.node("n1");
  const MemId disk = b.mem("n0.disk", Bytes(1) << 40, MemoryKind::Disk, n0);
  const MemId ram0 = b.mem("n0.ram", 100 * MB, MemoryKind::Host, n0);
  const MemId ram1 = b.mem("n1.ram", 100 * MB, MemoryKind::Host, n1);
  const ChannelId c_disk = b.channel(disk, ram0, 1e6);
  const ChannelId c_lan = b.channel(ram0, ram1, 1e6);
  const DeviceId cpu0 = b.dev("n0.cpu", ram0);
  const DeviceId cpu1 = b.dev("n1.cpu", ram1);
  b.timing(0, DataKind::SceneData, 1e9);
  const DeviceGraph g = b.build();
  JobPool pool;
  const BlockId a = add_block(pool, "sceneA", DataKind::SceneData, MB);
  const BlockId c = add_block(pool, "sceneC", DataKind::SceneData, MB);
  const JobId j0 = add_job(pool, "j0", 0, {a});
  const JobId j1 = add_job(pool, "j1", 0, {a});
  Schedule s(g, pool);
  auto epochs = [&] { return std::pair{s.node_epoch(n0), s.node_epoch(n1)}; };
  s.put_initial(a, disk);
  auto e = epochs();
  EXPECT_EQ(e.second, 0u) << "a copy on n0 leaves n1 as it was";
  // A load and an E-job on n0 touch n0 only.
  const ActivityId t0 = s.commit_transfer(a, c_disk, j0, 0, s.admission(ram0, MB, {}));
  s.commit_exec(j0, cpu0, 0, {});
  EXPECT_GT(s.node_epoch(n0), e.first);
  EXPECT_EQ(s.node_epoch(n1), e.second);
  // A LAN transfer touches both ends; an E-job on n1 touches n1 only.
  e = epochs();
  s.commit_transfer(a, c_lan, j1, s.activity(t0).end, s.admission(ram1, MB, {}));
  EXPECT_GT(s.node_epoch(n0), e.first);
  EXPECT_GT(s.node_epoch(n1), e.second);
  e = epochs();
  s.commit_exec(j1, cpu1, 0, {});
  EXPECT_EQ(s.node_epoch(n0), e.first);
  EXPECT_GT(s.node_epoch(n1), e.second);
  // Starts and ends move the nodes of what started or ended.
  e = epochs();
  s.on_started(t0, 0);
  EXPECT_GT(s.node_epoch(n0), e.first);
  EXPECT_EQ(s.node_epoch(n1), e.second);
  // A reprojection that moves nothing earlier moves no epoch; the load ending early (it
  // was planned to end at 1 s) pulls the LAN transfer and n1's E-job forward: both move.
  s.reproject(0.5);
  e = epochs();
  s.reproject(0.6);
  EXPECT_EQ(epochs(), e);
  s.on_finished(t0, 0.7);
  e = epochs();
  s.reproject(0.7);
  EXPECT_GT(s.node_epoch(n1), e.second) << "n1's work now starts earlier than planned";
  // A copy placed on n1 touches n1 only.
  e = epochs();
  s.put_initial(c, ram1, 0, false);
  EXPECT_EQ(s.node_epoch(n0), e.first);
  EXPECT_GT(s.node_epoch(n1), e.second);
}

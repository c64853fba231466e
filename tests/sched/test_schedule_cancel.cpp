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

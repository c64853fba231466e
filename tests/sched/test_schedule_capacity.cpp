// Capacity accounting when a workload puts data on a memory device without admission (new
// ray queues of the real renderer): the device may then hold more than its capacity, and
// admission must free the excess before admitting anything (regression: the free space was
// computed unsigned and wrapped around, admitting everything).
#include <gtest/gtest.h>

#include "dcg_fixture.hpp"
#include "sched/policy/unplaced.hpp"

using namespace rayline;
using namespace rayline::testing;

TEST(ScheduleCapacity, OverfullDeviceAdmitsNothingUntilFreed) {
  DcgBuilder b;
  const MemId disk = b.mem("disk", Bytes(1) << 40, MemoryKind::Disk);
  const MemId ram = b.mem("ram", 1000);
  b.channel(disk, ram, 1e6);
  b.g.finalize();
  JobPool pool;
  const BlockId cached = add_block(pool, "scene0", DataKind::SceneData, 400);
  const BlockId queue = add_block(pool, "rays", DataKind::RayQueue, 900);
  pool.block(queue).consumed = true;
  Schedule s(b.g, pool);
  s.put_initial(cached, disk);
  s.put_initial(cached, ram, 0, false);  // a cached copy (evictable)
  s.put_initial(queue, ram, 0, false);   // 1300 bytes on a 1000-byte device
  ASSERT_GT(s.used(ram), b.g.memories[ram].capacity);
  // 100 bytes fit only once the cached copy goes (the queue cannot be evicted).
  const auto adm = s.admission(ram, 100, {});
  ASSERT_NE(adm.at, kNever);
  ASSERT_EQ(adm.victims.size(), 1u);
  EXPECT_EQ(adm.victims[0].first, cached);
  // 200 bytes cannot fit even then: 1300 - 400 + 200 > 1000.
  EXPECT_EQ(s.admission(ram, 200, {}).at, kNever);
}

// why_unplaceable (sched/policy/unplaced.hpp): the static reason a job can run nowhere, for the
// device that comes closest; empty when some device could take it.
TEST(Unplaceable, NamesTheSizeThePathOrTheJobType) {
  DcgBuilder b;
  const MemId disk = b.mem("n.disk", Bytes(1) << 40, MemoryKind::Disk);
  const MemId ram = b.mem("n.ram", 1000);
  const MemId gpu = b.mem("n.gpumem", 5000, MemoryKind::Gpu);
  b.dev("n.cpu", ram);
  b.dev("n.gpu", gpu, ComputeKind::Gpu);
  b.channel(disk, ram, 1e6);
  b.channel(ram, gpu, 1e6);  // the GPU is fed through RAM only
  b.timing(0, DataKind::SceneData, 1e6);
  b.g.finalize();
  JobPool pool;
  const BlockId small = add_block(pool, "small", DataKind::SceneData, 500);
  const BlockId mid = add_block(pool, "mid", DataKind::SceneData, 3000);
  const BlockId huge = add_block(pool, "huge", DataKind::SceneData, 9000);
  const JobId fits = add_job(pool, "fits", 0, {small});
  const JobId relay = add_job(pool, "relay", 0, {mid});   // fits the GPU, but not RAM on the way
  const JobId too_big = add_job(pool, "too_big", 0, {huge});
  const JobId no_type = add_job(pool, "no_type", 1, {small});  // nobody runs job type 1
  Schedule s(b.g, pool);
  for (BlockId x : {small, mid, huge}) s.put_initial(x, disk);

  EXPECT_EQ(why_unplaceable(fits, pool, s), "");
  const std::string r = why_unplaceable(relay, pool, s);
  EXPECT_NE(r.find("n.gpu:"), std::string::npos) << r;
  EXPECT_NE(r.find("'mid'"), std::string::npos) << r;
  EXPECT_NE(r.find("no chain of channels"), std::string::npos) << r;
  const std::string t = why_unplaceable(too_big, pool, s);
  EXPECT_NE(t.find("9e-06 GB"), std::string::npos) << t;
  EXPECT_NE(t.find("(n.gpumem) holds 5e-06 GB"), std::string::npos) << t;
  EXPECT_NE(why_unplaceable(no_type, pool, s).find("runs job type Compute"), std::string::npos);
  // Once the mid block is on the GPU's memory already, nothing stands in the way.
  s.put_initial(mid, gpu);
  EXPECT_EQ(why_unplaceable(relay, pool, s), "");
  // An input no memory device holds yet is the output of a job still to run: no obstacle.
  const BlockId later = add_block(pool, "later", DataKind::SceneData, 3000);
  const JobId consumer = add_job(pool, "consumer", 0, {later});
  Schedule s2(b.g, pool);
  EXPECT_EQ(why_unplaceable(consumer, pool, s2), "");
}

// first_unplaceable looks at every queued job, not just the oldest: a stream whose oldest
// job can run but a later one never can is a stall all the same (sim/simulation.cpp), and
// the summary names the job that can never run.
TEST(Unplaceable, TheFirstJobThatCanNeverRunIsFoundBehindRunnableOnes) {
  DcgBuilder b;
  const MemId disk = b.mem("n.disk", Bytes(1) << 40, MemoryKind::Disk);
  const MemId ram = b.mem("n.ram", 1000);
  b.dev("n.cpu", ram);
  b.channel(disk, ram, 1e6);
  b.timing(0, DataKind::SceneData, 1e6);
  b.g.finalize();
  JobPool pool;
  const BlockId small = add_block(pool, "small", DataKind::SceneData, 500);
  const BlockId huge = add_block(pool, "huge", DataKind::SceneData, 9000);
  add_job(pool, "runs0", 0, {small});
  add_job(pool, "runs1", 0, {small});
  const JobId never = add_job(pool, "never", 0, {huge});
  add_job(pool, "never_too", 0, {huge});
  Schedule s(b.g, pool);
  for (BlockId x : {small, huge}) s.put_initial(x, disk);
  EXPECT_EQ(first_unplaceable(pool, s), never);
  const std::string msg = unplaced_summary(pool, s);
  EXPECT_NE(msg.find("4 job(s)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("job 'never': its inputs and outputs need"), std::string::npos) << msg;
  // Without such a job: kNone, and the summary names the oldest queued job.
  JobPool ok;
  const BlockId b0 = add_block(ok, "small", DataKind::SceneData, 500);
  add_job(ok, "runs", 0, {b0});
  Schedule s2(b.g, ok);
  s2.put_initial(b0, disk);
  EXPECT_EQ(first_unplaceable(ok, s2), kNone);
  EXPECT_NE(unplaced_summary(ok, s2).find("job 'runs': no device had room"), std::string::npos);
}

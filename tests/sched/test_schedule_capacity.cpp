// Capacity accounting when a workload puts data on a memory device without admission (new
// ray queues of the real renderer): the device may then hold more than its capacity, and
// admission must free the excess before admitting anything (regression: the free space was
// computed unsigned and wrapped around, admitting everything).
#include <gtest/gtest.h>

#include "dcg_fixture.hpp"

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

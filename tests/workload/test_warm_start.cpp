// Warm start (workload/warm_start.hpp): placements respect every capacity, take the most
// used blocks first, skip a block that does not fit for a smaller one that does, and
// leave disks and memories without compute devices alone; the expected block visits of a
// hand-checked profile (intersections and shadow rays); and a warm run starts with the blocks in place.
#include <gtest/gtest.h>

#include <random>

#include "sched/dcg_fixture.hpp"
#include "sched/io/platform_loader.hpp"
#include "workload/path_trace_workload.hpp"
#include "workload/ray_stream.hpp"
#include "workload/two_cell_profile.hpp"
#include "workload/warm_start.hpp"

using namespace rayline;

namespace {

BlockId scene_block(JobPool& pool, int i, Bytes bytes) {
  DataBlock d;
  d.name = "scene" + std::to_string(i);
  d.kind = DataKind::SceneData;
  d.bytes = bytes;
  return pool.add_block(d);
}

}  // namespace

TEST(WarmStart, MostUsedFirstWithinTheShareOfEveryMemory) {
  const DeviceGraph g = rayline::testing::three_node_stream_cluster();  // RAM 2 GiB, GPU memory 1 GiB per node
  JobPool pool;
  Schedule s(g, pool);
  std::vector<BlockId> blocks;
  const Bytes MiB = Bytes(1) << 20;
  // Use order: 0 (900 MiB), 1 (700 MiB), 2 (600 MiB), 3 (100 MiB).
  const std::vector<Bytes> sizes = {900 * MiB, 700 * MiB, 600 * MiB, 100 * MiB};
  for (int i = 0; i < 4; ++i) blocks.push_back(scene_block(pool, i, sizes[static_cast<std::size_t>(i)]));
  const std::vector<double> use = {4, 3, 2, 1};
  const std::size_t placed = warm_start(s, pool, blocks, use, WarmStart{});
  for (std::size_t m = 0; m < g.memories.size(); ++m) {
    const MemoryDevice& md = g.memories[m];
    const auto mem = static_cast<MemId>(m);
    EXPECT_LE(s.used(mem), static_cast<Bytes>(0.75 * static_cast<double>(md.capacity))) << md.name;
    if (md.kind == MemoryKind::Disk) {
      EXPECT_EQ(s.used(mem), 0u) << md.name;
    }
    if (md.kind == MemoryKind::Host) {  // 1536 MiB: 900, not 700 (1600), 600 (1500), not 100 (1600)
      EXPECT_TRUE(s.copy_at(blocks[0], mem));
      EXPECT_FALSE(s.copy_at(blocks[1], mem));
      EXPECT_TRUE(s.copy_at(blocks[2], mem));
      EXPECT_FALSE(s.copy_at(blocks[3], mem));
    }
    if (md.kind == MemoryKind::Gpu) {  // 768 MiB: 700 is the most used block that fits
      EXPECT_FALSE(s.copy_at(blocks[0], mem));
      EXPECT_TRUE(s.copy_at(blocks[1], mem));
      EXPECT_FALSE(s.copy_at(blocks[3], mem)) << "700 + 100 MiB exceed 768 MiB";
    }
    for (BlockId b : blocks)
      if (const Copy* c = s.copy_at(b, mem)) {
        EXPECT_FALSE(c->origin) << "warm copies are caches";
      }
  }
  EXPECT_EQ(placed, 3u * 3u);
}

TEST(WarmStart, RandomPlatformsNeverExceedACapacity) {
  for (int seed = 0; seed < 40; ++seed) {
    std::mt19937 rng(seed);
    rayline::testing::DcgBuilder b;
    const int nodes = std::uniform_int_distribution<int>(1, 4)(rng);
    for (int n = 0; n < nodes; ++n) {
      const NodeId node = b.node("n" + std::to_string(n));
      const MemId disk = b.mem("n" + std::to_string(n) + ".disk", Bytes(1) << 40, MemoryKind::Disk, node);
      const MemId ram = b.mem("n" + std::to_string(n) + ".ram", std::uniform_int_distribution<Bytes>(1, 4000)(rng) << 20,
                              MemoryKind::Host, node);
      b.half_duplex(disk, ram, 150e6);
      b.dev("n" + std::to_string(n) + ".cpu", ram);
    }
    const DeviceGraph g = b.build();
    JobPool pool;
    Schedule s(g, pool);
    std::vector<BlockId> blocks;
    std::vector<double> use;
    for (int i = 0; i < 50; ++i) {
      blocks.push_back(scene_block(pool, i, std::uniform_int_distribution<Bytes>(1, 500)(rng) << 20));
      use.push_back(std::uniform_real_distribution<double>(0, 1)(rng));
    }
    const double share = std::uniform_real_distribution<double>(0, 1)(rng);
    warm_start(s, pool, blocks, use, WarmStart{share, share, {}});
    for (std::size_t m = 0; m < g.memories.size(); ++m)
      if (g.memories[m].kind == MemoryKind::Host) {
        EXPECT_LE(static_cast<double>(s.used(static_cast<MemId>(m))), share * static_cast<double>(g.memories[m].capacity))
            << "seed " << seed;
      }
  }
}

TEST(WarmStart, UseIsTheExpectedIntersectAndShadowVisits) {
  // Two cells: camera rays enter cell 0 (alpha 0.5, beta 0.5, misses to cell 1); cell 1
  // lets every ray escape; one bounce only. Per camera ray: intersections 1 in cell 0 and
  // 0.5 in cell 1, and 0.5 hits in cell 0, each with a shadow ray ending there.
  const SceneProfile p = rayline::testing::two_cell_profile(1);
  const std::vector<double> v = expected_block_visits(p);
  ASSERT_EQ(v.size(), 2u);
  EXPECT_NEAR(v[0], 1.5, 1e-12);
  EXPECT_NEAR(v[1], 0.5, 1e-12);
}

TEST(WarmStart, WarmRayStreamStartsWithTheHotBlocksResident) {
  const DeviceGraph g = rayline::testing::three_node_stream_cluster();
  for (const bool warm : {false, true}) {
    JobPool pool;
    Schedule s(g, pool);
    RayStreamOptions o;
    o.blocks = 20;
    o.scene_bytes = Bytes(4) << 30;
    o.warm = warm;
    RayStreamWorkload wl(g, o);
    wl.start(0, pool, s);
    const MemId ram = g.find_memory("n0.ram");
    std::size_t resident = 0;
    for (std::size_t b = 0; b < pool.block_count(); ++b)
      if (pool.block(static_cast<BlockId>(b)).kind == DataKind::SceneData && s.copy_at(static_cast<BlockId>(b), ram)) ++resident;
    if (warm) {
      EXPECT_GT(resident, 0u);
      EXPECT_TRUE(s.copy_at(0, ram)) << "block 0 is the most popular (Zipf)";
    } else {
      EXPECT_EQ(resident, 0u);
    }
  }
}

// SDC details beyond the paper's examples: a memory device that holds (or is receiving) a
// block never gets a second copy routed into it, and FetchBound's bounds bracket SDC.
#include <gtest/gtest.h>

#include <random>

#include "dcg_fixture.hpp"
#include "sched/fetch_bound.hpp"
#include "sched/fetch_path.hpp"

using namespace rayline;

TEST(FetchPath, NeverRoutesIntoAMemoryThatAlreadyReceivesTheBlock) {
  rayline::testing::DcgBuilder b;
  const MemId m0 = b.mem("m0"), m1 = b.mem("m1"), m2 = b.mem("m2"), m3 = b.mem("m3");
  const ChannelId slow = b.channel(m0, m1, 10e6);  // 100 MB: 10 s
  b.channel(m0, m2, 100e6);
  b.channel(m2, m1, 100e6);
  b.channel(m1, m3, 100e6);
  DeviceGraph g = b.build();
  JobPool pool;
  DataBlock w;
  w.name = "w";
  w.kind = DataKind::SceneData;
  w.bytes = 100'000'000;
  const BlockId wb = pool.add_block(w);
  Schedule s(g, pool);
  s.put_initial(wb, m0);
  s.commit_transfer(wb, slow, kNone, 0, s.admission(m1, w.bytes, {}));  // m1 receives it at t = 10
  FetchPathFinder f(s);
  // m0 -> m2 -> m1 would land at 2 s, but m1 already has its (incoming) copy.
  EXPECT_DOUBLE_EQ(f.arrival(wb, m1), 10.0);
  EXPECT_DOUBLE_EQ(f.arrival(wb, m3), 11.0);
  std::vector<ChannelId> p;
  f.path(wb, m3, p);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(g.channels[p[0]].from, m1);
}

// FetchBound::lower_bound <= SDC arrival <= FetchBound::direct_upper_bound on random
// graphs with random busy channels and holders.
TEST(FetchPath, BoundsBracketSdcOnRandomGraphs) {
  std::mt19937 rng(9);
  int checked = 0;
  for (int inst = 0; inst < 200; ++inst) {
    rayline::testing::DcgBuilder b;
    const int n = 3 + inst % 5;
    std::vector<MemId> m;
    for (int i = 0; i < n; ++i) m.push_back(b.mem("m" + std::to_string(i)));
    std::uniform_real_distribution<double> bw(10e6, 500e6), lat(0, 0.01), u(0, 1);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        if (i != j && u(rng) < 0.5) b.channel(m[static_cast<std::size_t>(i)], m[static_cast<std::size_t>(j)], bw(rng), lat(rng));
    DeviceGraph g = b.build();
    JobPool pool;
    std::vector<BlockId> blocks;
    for (int k = 0; k < 4; ++k) {
      DataBlock d;
      d.name = "b" + std::to_string(k);
      d.kind = DataKind::SceneData;
      d.bytes = static_cast<Bytes>(u(rng) * 200e6) + 1;
      blocks.push_back(pool.add_block(d));
    }
    Schedule s(g, pool);
    for (BlockId blk : blocks) s.put_initial(blk, m[std::uniform_int_distribution<std::size_t>(0, m.size() - 1)(rng)]);
    // Make some channels busy with transfers of block 0.
    for (std::size_t c = 0; c < g.channels.size(); ++c)
      if (u(rng) < 0.3 && s.copy_at(blocks[0], g.channels[c].from) && !s.copy_at(blocks[0], g.channels[c].to))
        s.commit_transfer(blocks[0], static_cast<ChannelId>(c), kNone, 0, s.admission(g.channels[c].to, pool.block(blocks[0]).bytes, {}));
    FetchPathFinder f(s);
    FetchBound fb(g);
    const Time now = u(rng) * 2;
    f.set_now(now);
    for (BlockId blk : blocks)
      for (MemId dst : m) {
        const Time a = f.arrival(blk, dst);
        const Time lb = fb.lower_bound(s, blk, dst, now);
        const Time ub = fb.direct_upper_bound(s, blk, dst, now);
        EXPECT_LE(lb, a * (1 + 1e-12) + 1e-12) << "instance " << inst;
        EXPECT_GE(ub, a * (1 - 1e-12) - 1e-12) << "instance " << inst;
        ++checked;
      }
  }
  EXPECT_GT(checked, 1000);
}

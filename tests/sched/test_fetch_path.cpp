// SDC details beyond the paper's examples: a memory device that holds (or is receiving) a
// block never gets a second copy routed into it, and FetchBound's bounds bracket SDC. The
// planning-speed caches answer exactly what a fresh computation answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <iterator>
#include <random>

#include "dcg_fixture.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/policy/gmb/arrival_bound.hpp"
#include "sched/sdc/fetch_bound.hpp"
#include "sched/sdc/fetch_path.hpp"

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

// A block on one memory device (a ray queue) whose relayed path ties exactly with the
// direct hop: the planner's shortcut (FetchPathFinder::single_holder_direct) takes the
// direct hop, and so does the full Dijkstra tree, which relaxes the holder's channels first
// and replaces a label only by a smaller one. When the relay is strictly faster, both take it.
TEST(FetchPath, SingleHolderTieTakesTheDirectHopAsTheTreeDoes) {
  for (const double direct_bw : {50e6, 40e6}) {  // direct hop of 100 MB: 2 s (a tie), 2.5 s
    rayline::testing::DcgBuilder b;
    const MemId h = b.mem("h"), r = b.mem("r"), m = b.mem("m");
    const ChannelId direct = b.channel(h, m, direct_bw);
    const ChannelId first = b.channel(h, r, 100e6);   // 1 s
    const ChannelId second = b.channel(r, m, 100e6);  // 1 s, busy until 1 s below
    DeviceGraph g = b.build();
    JobPool pool;
    const Bytes size = 100'000'000;
    const BlockId qb = rayline::testing::add_block(pool, "rays", DataKind::RayQueue, size);
    const BlockId ob = rayline::testing::add_block(pool, "other", DataKind::RayQueue, size);
    Schedule s(g, pool);
    s.put_initial(qb, h);
    s.put_initial(ob, r);
    s.commit_transfer(ob, second, kNone, 0, s.admission(m, size, {}));  // r -> m busy over [0, 1]
    ASSERT_EQ(s.channel_finish(second), 1.0);
    FetchBound fb(g);
    FetchPathFinder fast(s), tree(s);
    fast.set_bounds(&fb);
    std::vector<ChannelId> pf, pt;
    fast.path(qb, m, pf);
    tree.path(qb, m, pt);
    EXPECT_EQ(pf, pt) << "direct hop of " << direct_bw;
    const std::vector<ChannelId> want = direct_bw == 50e6 ? std::vector<ChannelId>{direct} : std::vector<ChannelId>{first, second};
    EXPECT_EQ(pf, want);
    EXPECT_EQ(fast.arrival_within(qb, m, -kNever, [](Time) { return false; }), 2.0);
  }
}

// A memoised path proved the only best one stops being so once bookings on a resource it
// shares with another path delay both to the same arrival. arrival_within() re-stamps the
// delayed path when it meets a lower bound raised in between; path() must not then take it
// as the only best one (GmbEquivalence's random instances found a case), but
// ask the tree, which here takes the other holder's channel (popped first).
TEST(FetchPath, RestampedPathAfterARaisedBoundIsNoLongerUnique) {
  rayline::testing::DcgBuilder b;
  const MemId h1 = b.mem("h1"), h2 = b.mem("h2"), m = b.mem("m"), x = b.mem("x");
  const ResourceId in = b.resource("m.in", 100e6), out1 = b.resource("h1.out", 100e6), out2 = b.resource("h2.out", 100e6);
  const ChannelId c1 = b.channel(h1, m, 100e6, 0, {out1, in});  // 100 MB: 1 s
  const ChannelId c2 = b.channel(h2, m, 100e6, 0, {out2, in});
  const ChannelId busy_out2 = b.channel(h2, x, 1e6, 0, {out2});  // slow: no relay via x competes
  const ChannelId busy_in = b.channel(x, m, 1e6, 0, {in});
  DeviceGraph g = b.build();
  JobPool pool;
  const BlockId w = rayline::testing::add_block(pool, "w", DataKind::SceneData, 100'000'000);
  const BlockId f2 = rayline::testing::add_block(pool, "f2", DataKind::SceneData, 900'000);      // 0.9 s on busy_out2
  const BlockId fin = rayline::testing::add_block(pool, "fin", DataKind::SceneData, 2'000'000);  // 2 s on busy_in
  Schedule s(g, pool);
  s.put_initial(w, h1, 0.2);
  s.put_initial(w, h2, 0.0);
  s.put_initial(f2, h2);
  s.put_initial(fin, x);
  s.commit_transfer(f2, busy_out2, kNone, 0, s.admission(x, 900'000, {}));  // h2's port busy until 0.9
  FetchBound fb(g);
  FetchPathFinder fast(s);
  fast.set_bounds(&fb);
  const auto never = [](Time) { return false; };
  // c1 lands at 1.2 s, c2 at 1.9 s: c1 is the only best path, and memoised as such.
  ASSERT_EQ(fast.arrival_within(w, m, -kNever, never), 1.2);
  std::vector<ChannelId> p;
  fast.path(w, m, p);
  EXPECT_EQ(p, std::vector<ChannelId>{c1});
  // m's port busy until 2 s: both land at 3 s, a tie.
  s.commit_transfer(fin, busy_in, kNone, 0, s.admission(m, 2'000'000, {}));
  // A selection for which 3 s already loses raises the memo's bound to 3 s.
  EXPECT_EQ(fast.arrival_within(w, m, -kNever, [](Time t) { return t > 2.5; }), kNever);
  fast.path(w, m, p);
  FetchPathFinder tree(s);  // no bounds: the full tree
  std::vector<ChannelId> pt;
  tree.path(w, m, pt);
  EXPECT_EQ(pt, std::vector<ChannelId>{c2});
  EXPECT_EQ(p, pt);
  EXPECT_EQ(fast.arrival_within(w, m, -kNever, never), 3.0);
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

// ---- planning-speed caches: cached / cut answers equal fresh ones ------------
namespace {

struct RandomState {
  DeviceGraph g;
  JobPool pool;
  std::vector<BlockId> blocks;
  std::vector<MemId> m;
};

// Random graph: some channels on shared resources (contention, equal finish times), some
// round bandwidths (ties), random holders (1-3 per block, some not yet ready).
RandomState random_state(std::mt19937& rng, int inst) {
  RandomState r;
  rayline::testing::DcgBuilder b;
  const int n = 3 + inst % 6;
  std::uniform_real_distribution<double> bw(10e6, 500e6), lat(0, 0.01), u(0, 1);
  for (int i = 0; i < n; ++i)
    r.m.push_back(b.mem("m" + std::to_string(i), u(rng) < 0.15 ? Bytes(50'000'000) : Bytes(1) << 40));
  const ResourceId shared = b.resource("shared", 100e6);
  const bool round = inst % 3 == 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (i != j && u(rng) < 0.5) {
        const double w = round ? 100e6 : bw(rng);
        std::vector<ResourceId> res;
        if (u(rng) < 0.3) res.push_back(shared);
        b.channel(r.m[static_cast<std::size_t>(i)], r.m[static_cast<std::size_t>(j)], w, round ? 0.001 : lat(rng), res);
      }
  r.g = b.build();
  for (int k = 0; k < 5; ++k) {
    DataBlock d;
    d.name = "b" + std::to_string(k);
    d.kind = k % 2 ? DataKind::RayQueue : DataKind::SceneData;
    d.bytes = round ? Bytes(20'000'000) * static_cast<Bytes>(1 + k % 3) : static_cast<Bytes>(u(rng) * 150e6) + 1;
    r.blocks.push_back(r.pool.add_block(d));
  }
  return r;
}

// Every block of r initially on one random memory device of r.
void place_blocks_randomly(const RandomState& r, Schedule& s, std::mt19937& rng) {
  for (BlockId blk : r.blocks) s.put_initial(blk, r.m[std::uniform_int_distribution<std::size_t>(0, r.m.size() - 1)(rng)]);
}

// Every block of r on 1-3 random memory devices of r (the first its origin), 30 % of the
// copies ready only later.
void place_holders_randomly(const RandomState& r, Schedule& s, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  for (BlockId blk : r.blocks) {
    const int holders = 1 + static_cast<int>(u(rng) * 3);
    for (int h = 0; h < holders; ++h) {
      const MemId at = r.m[std::uniform_int_distribution<std::size_t>(0, r.m.size() - 1)(rng)];
      if (!s.copy_at(blk, at)) s.put_initial(blk, at, u(rng) < 0.3 ? u(rng) : 0.0, h == 0);
    }
  }
}

// One random hop committed (more contention and a new holder), when the block is on the
// channel's source and not yet on its destination. `at` gives the T-job's earliest start.
template <class At>
void commit_random_hop(const RandomState& r, Schedule& s, std::mt19937& rng, const At& at) {
  std::uniform_real_distribution<double> u(0, 1);
  if (r.g.channels.empty()) return;
  const ChannelId c = static_cast<ChannelId>(u(rng) * static_cast<double>(r.g.channels.size()));
  const BlockId blk = r.blocks[static_cast<std::size_t>(u(rng) * static_cast<double>(r.blocks.size()))];
  const Channel& ch = r.g.channels[static_cast<std::size_t>(c)];
  if (s.copy_at(blk, ch.from) && !s.copy_at(blk, ch.to)) {
    const auto adm = s.admission(ch.to, r.pool.block(blk).bytes, {});
    if (adm.at != kNever) s.commit_transfer(blk, c, kNone, at(), adm);
  }
}

// Eq. 3 along a path from its source holder (what committing it would achieve).
Time chain(const Schedule& s, BlockId b, const std::vector<ChannelId>& p, Time now) {
  const DeviceGraph& g = s.graph();
  const Copy* src = s.copy_at(b, g.channels[static_cast<std::size_t>(p.front())].from);
  if (!src) return -1;
  Time t = std::max(now, s.copy_ready(*src));
  for (ChannelId c : p) t = std::max(t, s.channel_finish(c)) + g.transfer_time(c, s.pool().block(b).bytes);
  return t;
}

// Six blocks: scene data of about 50 MB (even k) and ray queues of up to 32 MB (odd k).
void add_cluster_blocks(RandomState& r, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  for (int k = 0; k < 6; ++k) {
    DataBlock d;
    d.name = "b" + std::to_string(k);
    d.kind = k % 2 ? DataKind::RayQueue : DataKind::SceneData;
    d.consumed = k % 2 == 1;
    d.bytes = k % 2 ? static_cast<Bytes>(u(rng) * 32e6) + 1 : static_cast<Bytes>((0.9 + 0.2 * u(rng)) * 50e6);
    r.blocks.push_back(r.pool.add_block(d));
  }
}

// Cluster-shaped random platform (the paper's Sec. 6 shape, small): 2-5 nodes, each a
// disk and a RAM (SATA, one half-duplex resource) and maybe a GPU memory behind PCIe; a
// LAN channel between every two RAMs that occupies the sender's port out and the
// receiver's port in (1 Gb/s or 100 Mb/s ports, the channel at the slower). Scene blocks
// on every disk, ray queues each in one RAM: the ray queue's single-holder shortcut, its
// first-hop floor and dead ends (a holder's own disk and GPU), and the GPU behind its host
// all arise here.
RandomState random_cluster_state(std::mt19937& rng, int inst) {
  RandomState r;
  rayline::testing::DcgBuilder b;
  std::uniform_real_distribution<double> u(0, 1);
  const int nodes = 2 + inst % 4;
  std::vector<MemId> rams, disks;
  std::vector<ResourceId> port_out, port_in;
  std::vector<double> port_bw;
  for (int i = 0; i < nodes; ++i) {
    const std::string n = "n" + std::to_string(i);
    const NodeId node = b.node(n);
    disks.push_back(b.mem(n + ".disk", Bytes(1) << 40, MemoryKind::Disk, node));
    rams.push_back(b.mem(n + ".ram", u(rng) < 0.2 ? Bytes(60'000'000) : Bytes(8) << 30, MemoryKind::Host, node));
    b.half_duplex(disks.back(), rams.back(), 150e6, 0.008);
    if (u(rng) < 0.5) {
      const MemId gpu = b.mem(n + ".gpu", Bytes(6) << 30, MemoryKind::Gpu, node);
      b.full_duplex(rams.back(), gpu, 6e9, 1e-5);
      r.m.push_back(gpu);
    }
    port_bw.push_back(u(rng) < 0.5 ? 125e6 : 12.5e6);
    port_out.push_back(b.resource(n + ".out", port_bw.back()));
    port_in.push_back(b.resource(n + ".in", port_bw.back()));
  }
  for (int i = 0; i < nodes; ++i)
    for (int j = 0; j < nodes; ++j)
      if (i != j) {
        const auto si = static_cast<std::size_t>(i), sj = static_cast<std::size_t>(j);
        b.channel(rams[si], rams[sj], std::min(port_bw[si], port_bw[sj]), 1e-4, {port_out[si], port_in[sj]});
      }
  r.m.insert(r.m.end(), rams.begin(), rams.end());
  r.m.insert(r.m.end(), disks.begin(), disks.end());
  r.g = b.build();
  add_cluster_blocks(r, rng);
  return r;
}

// A switched network as platform files describe it (`networks`, the loader expands it):
// 6-16 nodes, with or without a GPU, NICs of 100 Mb/s, 1 Gb/s or 10 Gb/s, in no racks or
// in 2-3 racks (uplinks of random speed) with or without a backbone. Long enough for the
// search's network runs and relay runs (FetchBound's NetworkFloor), which decide about a
// whole group of channels at once.
RandomState random_network_state(std::mt19937& rng, int inst, int min_nodes = 6) {
  RandomState r;
  std::uniform_real_distribution<double> u(0, 1);
  const int nodes = min_nodes + inst % 11;
  const int racks = inst % 3 == 0 ? 0 : 2 + inst % 2;
  const bool backbone = racks == 0 ? inst % 2 == 1 : u(rng) < 0.7;
  const char* speeds[] = {"100Mb/s", "1Gb/s", "10Gb/s"};
  std::string net = R"({"name": "lan", "latency": "100us", "duplex": "full")";
  if (backbone) net += std::string(R"(, "backbone": {"bandwidth": ")") + speeds[1 + inst % 2] + R"(", "latency": "20us"})";
  if (racks > 0) {
    net += R"(, "racks": [)";
    for (int k = 0; k < racks; ++k)
      net += std::string(k ? ", " : "") + R"({"name": "r)" + std::to_string(k) + R"(", "uplink": ")" + speeds[std::uniform_int_distribution<int>(0, 2)(rng)] + "\"}";
    net += "]";
  }
  net += R"(, "members": [)";
  std::string node_list;
  for (int i = 0; i < nodes; ++i) {
    const std::string n = "n" + std::to_string(i);
    node_list += std::string(i ? ", " : "") + R"({"name": ")" + n + R"(", "type": ")" + (u(rng) < 0.5 ? "G" : "C") + "\"";
    if (u(rng) < 0.2) node_list += R"(, "memory": [{"name": "ram", "capacity": "60MB"}])";
    node_list += "}";
    net += std::string(i ? ", " : "") + R"({"node": ")" + n + R"(", "bandwidth": ")" + speeds[std::uniform_int_distribution<int>(0, 2)(rng)] + "\"";
    if (racks > 0) net += R"(, "rack": "r)" + std::to_string(i * racks / nodes) + "\"";
    net += "}";
  }
  net += "]}";
  const std::string cpu = R"({"name": "cpu", "kind": "cpu", "memory": "ram", "timing": {"RayIntersect": {"setup": "5us"}}})";
  const std::string sata = R"({"name": "sata", "kind": "sata", "between": ["disk", "ram"], "duplex": "half", "latency": "8ms", "bandwidth": "150MB/s"})";
  const std::string json = R"({"name": "random-network", "node_types": {
      "C": {"memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"}, {"name": "ram", "kind": "host", "capacity": "8GiB"}],
            "compute": [)" + cpu + R"(], "channels": [)" + sata + R"(]},
      "G": {"memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"}, {"name": "ram", "kind": "host", "capacity": "8GiB"},
                       {"name": "gpumem", "kind": "gpu", "capacity": "6GiB"}],
            "compute": [)" + cpu + R"(, {"name": "gpu", "kind": "gpu", "memory": "gpumem", "timing": {"RayIntersect": {"setup": "50us"}}}],
            "channels": [)" + sata + R"(, {"name": "pcie", "kind": "pcie", "between": ["ram", "gpumem"], "duplex": "full", "latency": "10us", "bandwidth": "6GB/s"}]}},
    "nodes": [)" + node_list + R"(], "networks": [)" + net + "]}";
  r.g = parse_platform(json, "random-network.json");
  for (std::size_t m = 0; m < r.g.memories.size(); ++m) r.m.push_back(static_cast<MemId>(m));
  add_cluster_blocks(r, rng);
  return r;
}

// Scene blocks on every disk (origins), sometimes also in a RAM; each ray queue in one RAM.
void place_cluster_blocks(const RandomState& r, Schedule& s, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<MemId> disks, rams;
  for (MemId m : r.m) {
    const MemoryKind k = r.g.memories[static_cast<std::size_t>(m)].kind;
    if (k == MemoryKind::Disk) disks.push_back(m);
    if (k == MemoryKind::Host) rams.push_back(m);
  }
  auto any_ram = [&] { return rams[std::uniform_int_distribution<std::size_t>(0, rams.size() - 1)(rng)]; };
  for (BlockId blk : r.blocks) {
    if (r.pool.block(blk).kind == DataKind::SceneData) {
      for (MemId d : disks) s.put_initial(blk, d);
      if (u(rng) < 0.3) {
        const MemId at = any_ram();
        if (r.g.memories[static_cast<std::size_t>(at)].capacity >= r.pool.block(blk).bytes) s.put_initial(blk, at, u(rng), false);
      }
    } else {
      s.put_initial(blk, any_ram(), u(rng) < 0.3 ? u(rng) : 0.0);
    }
  }
}

// arrival_within() (branch and bound, memo) against the full Dijkstra: the same bits for
// the exact answers, and the documented contract for `enough` / `lost`; path() with bounds
// (a unique best path or the tree's) has the arrival's Eq. 3 value; all of it again after
// more commits (memo validity by path stamps and holders versions).
template <class Make, class Place>
void expect_cut_search_equals_full_search(std::uint32_t seed, int instances, const Make& make, const Place& place,
                                          int& checked, int& cut) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  for (int inst = 0; inst < instances; ++inst) {
    RandomState r = make(rng, inst);
    Schedule s(r.g, r.pool);
    place(r, s, rng);
    const Time now = u(rng) * 0.5;
    FetchBound fb(r.g);
    FetchPathFinder cached(s);  // lives through the commits: its memo must stay right
    cached.set_now(now);
    cached.set_bounds(&fb);
    for (int round = 0; round < 4; ++round) {
      FetchPathFinder full(s);  // fresh: plain Dijkstra
      full.set_now(now);
      full.set_early_stop(0);
      for (BlockId blk : r.blocks)
        for (MemId dst : r.m) {
          const Time a = full.arrival(blk, dst);
          if (a < kNever && round % 2 == 1) {
            // Before the memo is refreshed (stale after the commits): the search cut at
            // `enough` answers with the label of an admissible path, never below a.
            const Time e = a * (0.5 + u(rng));
            const Time y = cached.arrival_within(blk, dst, e, [](Time) { return false; });
            EXPECT_GE(y, a);
            if (a <= e) EXPECT_LE(y, e);
            else EXPECT_EQ(y, a);
          }
          EXPECT_EQ(std::bit_cast<std::uint64_t>(cached.arrival_within(blk, dst, -kNever, [](Time) { return false; })),
                    std::bit_cast<std::uint64_t>(a))
              << "instance " << inst << " round " << round;
          if (a < kNever) {
            const Time t = a * (0.5 + u(rng));
            Time proven = -1;
            const Time x = cached.arrival_within(blk, dst, -kNever, [t](Time v) { return v > t; }, &proven);
            if (a <= t) {
              EXPECT_EQ(x, a);
            } else {
              EXPECT_EQ(x, kNever);
              EXPECT_LE(proven, a);
            }
            const Time e = a * (0.5 + u(rng));
            const Time y = cached.arrival_within(blk, dst, e, [](Time) { return false; });
            EXPECT_GE(y, a);
            if (a <= e) EXPECT_LE(y, e);
            else EXPECT_EQ(y, a);
            std::vector<ChannelId> p;
            cached.path(blk, dst, p);
            if (!s.copy_at(blk, dst)) {
              ASSERT_FALSE(p.empty()) << "instance " << inst;
              EXPECT_EQ(r.g.channels[static_cast<std::size_t>(p.back())].to, dst);
              for (std::size_t k = 1; k < p.size(); ++k)
                EXPECT_EQ(r.g.channels[static_cast<std::size_t>(p[k])].from, r.g.channels[static_cast<std::size_t>(p[k - 1])].to);
              EXPECT_EQ(chain(s, blk, p, now), a) << "instance " << inst;
              // The same channels as the plain Dijkstra tree's path (its tie-breaking).
              std::vector<ChannelId> tree_path;
              full.path(blk, dst, tree_path);
              EXPECT_EQ(p, tree_path) << "instance " << inst << " round " << round;
            }
          }
          ++checked;
        }
      cut += static_cast<int>(cached.cut_searches());
      // More contention and new holders: commit a few hops.
      for (int k = 0; k < 3; ++k) {
        commit_random_hop(r, s, rng, [&] { return now; });
      }
    }
  }
}

}  // namespace

TEST(FetchPath, CutSearchAndMemoEqualTheFullSearchOnRandomGraphs) {
  int checked = 0, cut = 0;
  expect_cut_search_equals_full_search(2026, 300, random_state, place_holders_randomly, checked, cut);
  EXPECT_GT(checked, 5000);
  EXPECT_GT(cut, 0);
}

TEST(FetchPath, CutSearchAndMemoEqualTheFullSearchOnRandomClusters) {
  int checked = 0, cut = 0;
  expect_cut_search_equals_full_search(34, 200, random_cluster_state, place_cluster_blocks, checked, cut);
  EXPECT_GT(checked, 5000);
  EXPECT_GT(cut, 0);
}

TEST(FetchPath, CutSearchAndMemoEqualTheFullSearchOnRandomNetworks) {
  int checked = 0, cut = 0;
  expect_cut_search_equals_full_search(61, 90, [](std::mt19937& rng, int inst) { return random_network_state(rng, inst); },
                                       place_cluster_blocks, checked, cut);
  EXPECT_GT(checked, 20000);
  EXPECT_GT(cut, 0);
}

// Past Schedule::kScannedCopies copies (a scene block on every disk of 17 to 27 nodes),
// copy_at() answers from a position index and FetchBound folds the disks' copies into one
// floor: the searches still equal the full Dijkstra bit for bit, copy_at() equals a scan,
// and the bounds stay below the arrival, within 1e-13 of the per-copy minimum.
TEST(FetchPath, ManyCopiesKeepSearchesExactAndBoundsBelow) {
  int checked = 0, cut = 0;
  auto large = [](std::mt19937& rng, int inst) { return random_network_state(rng, inst, 17); };
  expect_cut_search_equals_full_search(73, 24, large, place_cluster_blocks, checked, cut);
  EXPECT_GT(checked, 10000);
  std::mt19937 rng(74);
  std::uniform_real_distribution<double> u(0, 1);
  int many = 0;
  for (int inst = 0; inst < 12; ++inst) {
    RandomState r = large(rng, inst);
    Schedule s(r.g, r.pool);
    place_cluster_blocks(r, s, rng);
    const Time now = u(rng);
    for (int step = 0; step < 6; ++step) {
      FetchPathFinder full(s);
      full.set_now(now);
      FetchBound fb(r.g);
      for (BlockId blk : r.blocks) {
        const std::vector<Copy>& copies = s.copies(blk);
        if (copies.size() > Schedule::kScannedCopies) ++many;
        const double w = static_cast<double>(r.pool.block(blk).bytes);
        for (MemId dst : r.m) {
          const Copy* scanned = nullptr;
          for (const Copy& c : copies)
            if (c.mem == dst) scanned = &c;
          ASSERT_EQ(s.copy_at(blk, dst), scanned) << "instance " << inst;
          const Time a = full.arrival(blk, dst);
          const Time free_run = fb.free_run_bound(s, blk, dst, now);
          EXPECT_LE(fb.lower_bound(s, blk, dst, now), a * (1 + 1e-12) + 1e-12) << "instance " << inst;
          EXPECT_LE(fb.lower_bound_once(s, blk, dst, now), a * (1 + 1e-12) + 1e-12) << "instance " << inst;
          EXPECT_LE(free_run, a * (1 + 1e-12) + 1e-12) << "instance " << inst;
          // The per-copy minimum of max(now, ready) + the least uncontended fetch.
          Time exact = kNever;
          for (const Copy& c : copies) {
            if (c.mem == dst) {
              exact = std::max(now, s.copy_ready(c));
              break;
            }
            const auto ci = static_cast<std::size_t>(c.mem);
            exact = std::min(exact, std::max(now, s.copy_ready(c)) + fb.latency_to(dst)[ci] + w * fb.inv_bw_to(dst)[ci]);
          }
          if (exact < kNever) {
            EXPECT_LE(free_run, exact) << "instance " << inst;
            EXPECT_GE(free_run, exact * (1 - 1e-13)) << "instance " << inst;
          } else {
            EXPECT_EQ(free_run, kNever);
          }
          ++checked;
        }
      }
      commit_random_hop(r, s, rng, [&] { return now; });
    }
  }
  EXPECT_GT(many, 100) << "blocks with more copies than a scan handles";
}

// A destination whose incoming NIC is booked seconds ahead is settled after nearly every
// other device, so search() stops as soon as its label is final (no in-channel from a
// device not settled yet can lower it; a GPU memory's with its host's). On networks of
// 30-40 nodes with a few RAMs' NICs booked that way (and a few disks, so that a first label
// is often beaten later), the trees' arrivals and paths equal
// plain Dijkstra's bit for bit, the cached trees' answers for the other destinations
// too, and the stop happens.
TEST(FetchPath, EarlyStoppedSearchesEqualPlainDijkstra) {
  std::mt19937 rng(91);
  std::uniform_real_distribution<double> u(0, 1);
  std::uint64_t stops = 0;
  int checked = 0;
  for (int inst = 0; inst < 10; ++inst) {
    RandomState r = random_network_state(rng, inst, 30);
    Schedule s(r.g, r.pool);
    place_cluster_blocks(r, s, rng);
    std::vector<MemId> rams;
    for (MemId m : r.m)
      if (r.g.memories[static_cast<std::size_t>(m)].kind == MemoryKind::Host) rams.push_back(m);
    // Every block but the last two moved into `count` random RAMs from a memory of `from`
    // kind: their channels in are booked far ahead.
    auto book = [&](int count, MemoryKind from) {
      for (int k = 0; k < count; ++k) {
        const MemId d = rams[std::uniform_int_distribution<std::size_t>(0, rams.size() - 1)(rng)];
        for (std::size_t bi = 0; bi + 2 < r.blocks.size(); ++bi) {
          const BlockId blk = r.blocks[bi];
          if (s.copy_at(blk, d)) continue;
          for (ChannelId c : r.g.in_channels(d)) {
            const Channel& ch = r.g.channels[static_cast<std::size_t>(c)];
            if (r.g.memories[static_cast<std::size_t>(ch.from)].kind != from || !s.copy_at(blk, ch.from)) continue;
            const auto adm = s.admission(d, r.pool.block(blk).bytes, {});
            if (adm.at != kNever) s.commit_transfer(blk, c, kNone, 0, adm);
            break;
          }
        }
      }
    };
    book(3, MemoryKind::Host);  // three RAMs' NICs
    // Four RAMs' disks: their own disk becomes their slow way, so a search's first label
    // there is often beaten later through the network.
    book(4, MemoryKind::Disk);
    const Time now = u(rng) * 0.1;
    FetchPathFinder fast(s), reused(s);
    fast.set_now(now);
    fast.set_early_stop(1);  // checked at every settled device: the most chances to be wrong
    reused.set_now(now);
    for (BlockId blk : r.blocks)
      for (MemId dst : r.m) {
        FetchPathFinder plain(s), fresh(s);
        plain.set_now(now);
        plain.set_early_stop(0);
        fresh.set_now(now);
        fresh.set_early_stop(1);
        const Time a = plain.arrival(blk, dst);
        ASSERT_EQ(std::bit_cast<std::uint64_t>(fresh.arrival(blk, dst)), std::bit_cast<std::uint64_t>(a))
            << "instance " << inst;
        // One finder asked every destination in turn: trees reused where they answer.
        ASSERT_EQ(std::bit_cast<std::uint64_t>(reused.arrival(blk, dst)), std::bit_cast<std::uint64_t>(a))
            << "instance " << inst;
        std::vector<ChannelId> p0, p1, p2;
        plain.path(blk, dst, p0);
        fresh.path(blk, dst, p1);
        fast.path(blk, dst, p2);
        EXPECT_EQ(p1, p0) << "instance " << inst;
        EXPECT_EQ(p2, p0) << "instance " << inst;
        stops += fresh.early_stops();
        ++checked;
      }
  }
  EXPECT_GT(checked, 3000);
  EXPECT_GT(stops, 50u) << "searches stopped early";
}

// FetchBound::lower_bound() memoised by the attaining channel equals the bound recomputed
// from scratch, as commits make channels busier and add holders.
TEST(FetchBound, MemoisedLowerBoundEqualsFreshOne) {
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> u(0, 1);
  for (int inst = 0; inst < 150; ++inst) {
    RandomState r = random_state(rng, inst);
    Schedule s(r.g, r.pool);
    place_blocks_randomly(r, s, rng);
    FetchBound memoised(r.g);
    const Time now = u(rng);
    for (int step = 0; step < 12; ++step) {
      FetchBound fresh(r.g);
      for (BlockId blk : r.blocks)
        for (MemId dst : r.m)
          EXPECT_EQ(std::bit_cast<std::uint64_t>(memoised.lower_bound(s, blk, dst, now)),
                    std::bit_cast<std::uint64_t>(fresh.lower_bound_once(s, blk, dst, now)))
              << "instance " << inst << " step " << step;
      commit_random_hop(r, s, rng, [&] { return now; });
    }
  }
}

// FetchBound's all-pairs minima L and W (computed with leaves peeled off before
// Floyd-Warshall) equal a plain Floyd-Warshall over every device, on random graphs with
// leaves (both ways, one way only, parallel channels), chains of leaves and components of
// two devices.
TEST(FetchBound, AllPairsMinimaWithLeavesPeeledEqualPlainFloydWarshall) {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> bw(10e6, 500e6), lat(0, 0.01), u(0, 1);
  int leaves = 0;
  for (int inst = 0; inst < 300; ++inst) {
    rayline::testing::DcgBuilder b;
    std::vector<MemId> m;
    const int core = 1 + inst % 6;
    for (int i = 0; i < core; ++i) m.push_back(b.mem("c" + std::to_string(i)));
    for (int i = 0; i < core; ++i)
      for (int j = 0; j < core; ++j)
        if (i != j && u(rng) < 0.6) b.channel(m[static_cast<std::size_t>(i)], m[static_cast<std::size_t>(j)], bw(rng), lat(rng));
    const int extra = inst % 7;
    for (int k = 0; k < extra; ++k) {  // a leaf on any device so far (chains when on a leaf)
      const MemId v = b.mem("l" + std::to_string(k));
      const MemId to = m[std::uniform_int_distribution<std::size_t>(0, m.size() - 1)(rng)];
      const double r = u(rng);
      if (r < 0.8) b.channel(v, to, bw(rng), lat(rng));
      if (r > 0.2) b.channel(to, v, bw(rng), lat(rng));
      if (u(rng) < 0.2) b.channel(to, v, bw(rng), lat(rng));  // a parallel channel
      m.push_back(v);
      ++leaves;
    }
    const DeviceGraph g = b.build();
    const std::size_t n = g.memories.size();
    std::vector<double> L(n * n, kNever), W(n * n, kNever);
    for (std::size_t i = 0; i < n; ++i) L[i * n + i] = W[i * n + i] = 0;
    for (const Channel& c : g.channels) {
      const std::size_t k = static_cast<std::size_t>(c.from) * n + static_cast<std::size_t>(c.to);
      L[k] = std::min(L[k], c.latency);
      W[k] = std::min(W[k], 1.0 / c.bandwidth);
    }
    for (std::vector<double>* d : {&L, &W})
      for (std::size_t k = 0; k < n; ++k)
        for (std::size_t i = 0; i < n; ++i)
          for (std::size_t j = 0; j < n; ++j) (*d)[i * n + j] = std::min((*d)[i * n + j], (*d)[i * n + k] + (*d)[k * n + j]);
    const FetchBound fb(g);
    for (std::size_t to = 0; to < n; ++to)
      for (std::size_t from = 0; from < n; ++from) {
        const double l = fb.latency_to(static_cast<MemId>(to))[from], w = fb.inv_bw_to(static_cast<MemId>(to))[from];
        const double lw = L[from * n + to], ww = W[from * n + to];
        if (lw == kNever) {
          EXPECT_EQ(l, kNever) << "instance " << inst << " " << from << "->" << to;
          EXPECT_EQ(w, kNever) << "instance " << inst << " " << from << "->" << to;
          continue;
        }
        EXPECT_NEAR(l, lw, 1e-12 * lw + 1e-15) << "instance " << inst << " " << from << "->" << to;
        EXPECT_NEAR(w, ww, 1e-12 * ww + 1e-24) << "instance " << inst << " " << from << "->" << to;
      }
  }
  EXPECT_GT(leaves, 500);
}

// FetchBound::last_hop_floor() (the pre-search cut of arrival_within) never exceeds the
// SDC arrival, bit for bit (no tolerance: it is the last hop's Eq. 3 with max(l, F) >= F),
// on random graphs with shared resources, small memories, several holders (some of them
// sources reached only through the destination) and growing contention.
TEST(FetchBound, LastHopFloorNeverExceedsTheArrival) {
  std::mt19937 rng(4242);
  std::uniform_real_distribution<double> u(0, 1);
  int checked = 0, above_free = 0;
  for (int inst = 0; inst < 300; ++inst) {
    RandomState r = random_state(rng, inst);
    Schedule s(r.g, r.pool);
    place_holders_randomly(r, s, rng);
    const Time now = u(rng) * 0.5;
    FetchBound fb(r.g);
    for (int round = 0; round < 5; ++round) {
      FetchPathFinder full(s);
      full.set_now(now);
      for (BlockId blk : r.blocks)
        for (MemId dst : r.m) {
          if (s.copy_at(blk, dst)) continue;
          const Time a = full.arrival(blk, dst);
          const Time floor = fb.last_hop_floor(s, blk, dst);
          EXPECT_LE(floor, a) << "instance " << inst << " round " << round;
          if (a < kNever && floor > fb.free_run_bound(s, blk, dst, now)) ++above_free;
          ++checked;
        }
      for (int k = 0; k < 4; ++k) commit_random_hop(r, s, rng, [&] { return now + u(rng); });
    }
  }
  EXPECT_GT(checked, 5000);
  EXPECT_GT(above_free, 100);  // contention makes it bite where the uncontended bound does not
}

// ArrivalBound::assign_all() (members sorted once) builds exactly the groups that one
// assign() per block builds: the same ids, members in the same order, the same smallest
// current member, also with repeated blocks and after holders change.
TEST(ArrivalBound, AssignAllEqualsOneByOne) {
  std::mt19937 rng(515);
  std::uniform_real_distribution<double> u(0, 1);
  for (int inst = 0; inst < 200; ++inst) {
    RandomState r = random_state(rng, inst);
    for (int k = 0; k < 20; ++k) {  // more blocks, so that groups have several members
      DataBlock d;
      d.name = "x" + std::to_string(k);
      d.kind = DataKind::SceneData;
      d.bytes = static_cast<Bytes>(u(rng) * 4) * 10'000'000 + 1;  // repeated sizes too
      r.blocks.push_back(r.pool.add_block(d));
    }
    Schedule s(r.g, r.pool);
    for (BlockId blk : r.blocks) {
      const int holders = 1 + static_cast<int>(u(rng) * 2);
      for (int h = 0; h < holders; ++h) {
        const MemId at = r.m[static_cast<std::size_t>(u(rng) * 2) % r.m.size()];  // few signatures
        if (!s.copy_at(blk, at)) s.put_initial(blk, at, 0.0, h == 0);
      }
    }
    for (int round = 0; round < 3; ++round) {
      std::vector<BlockId> keys;
      for (BlockId blk : r.blocks)
        if (u(rng) < 0.7) keys.push_back(blk);
      if (!keys.empty()) keys.push_back(keys[static_cast<std::size_t>(u(rng) * static_cast<double>(keys.size()))]);
      std::shuffle(keys.begin(), keys.end(), rng);
      ArrivalBound one(r.g), all(r.g);
      one.reset(0);
      all.reset(0);
      for (BlockId k : keys) one.assign(s, k);
      all.assign_all(s, keys);
      ASSERT_EQ(one.group_count(), all.group_count());
      for (BlockId k : keys) EXPECT_EQ(one.group(s, k), all.group(s, k));
      for (std::size_t g = 0; g < one.group_count(); ++g) {
        const auto gi = static_cast<std::int32_t>(g);
        EXPECT_EQ(one.members(gi), all.members(gi)) << "instance " << inst;
        EXPECT_EQ(one.smallest(s, gi), all.smallest(s, gi));
      }
      commit_random_hop(r, s, rng, [] { return 0.0; });
    }
  }
}

// Schedule keeps FinishTime(c) per channel and a holder mask per block: both equal what
// they summarise, through commits and reproject().
TEST(Schedule, ChannelFinishAndHoldersStayInStepWithTimelines) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  for (int inst = 0; inst < 100; ++inst) {
    RandomState r = random_state(rng, inst);
    Schedule s(r.g, r.pool);
    place_blocks_randomly(r, s, rng);
    auto check = [&] {
      for (std::size_t c = 0; c < r.g.channels.size(); ++c) {
        Time t = 0;
        for (ResourceId q : r.g.channels[c].resources) t = std::max(t, s.resource_timeline(q).busy_until);
        EXPECT_EQ(s.channel_finish(static_cast<ChannelId>(c)), t);
      }
      for (BlockId blk : r.blocks)
        for (MemId dst : r.m) {
          const Copy* want = nullptr;
          for (const Copy& c : s.copies(blk))
            if (c.mem == dst) want = &c;
          EXPECT_EQ(s.copy_at(blk, dst), want);
        }
    };
    for (int step = 0; step < 10; ++step) {
      commit_random_hop(r, s, rng, [&] { return u(rng); });
      check();
    }
    for (std::size_t a = 0; a < s.activity_count(); ++a)
      if (u(rng) < 0.5) s.on_finished(static_cast<ActivityId>(a), s.activity(static_cast<ActivityId>(a)).end * (0.5 + u(rng)));
    s.reproject(2.0);
    check();
  }
}

// JobPool's queue keeps arrival order through removals (holes, squeezed out in bulk) and
// requeues.
static_assert(std::forward_iterator<JobPool::Queue::iterator>);

TEST(JobPool, QueueKeepsArrivalOrderThroughRemovalsAndRequeues) {
  std::mt19937 rng(11);
  JobPool pool;
  const BlockId b = rayline::testing::add_block(pool, "b", DataKind::Generic, 1);
  std::vector<JobId> ref;
  for (int i = 0; i < 300; ++i) ref.push_back(rayline::testing::add_job(pool, "j" + std::to_string(i), 0, {b}));
  std::vector<JobId> out;
  for (int step = 0; step < 2000; ++step) {
    if (!ref.empty() && (out.empty() || rng() % 3 != 0)) {
      const std::size_t k = rng() % ref.size();
      pool.mark_planned(ref[k], 0);
      out.push_back(ref[k]);
      ref.erase(ref.begin() + static_cast<std::ptrdiff_t>(k));
    } else {
      const std::size_t k = rng() % out.size();
      pool.requeue(out[k]);
      ref.push_back(out[k]);
      out.erase(out.begin() + static_cast<std::ptrdiff_t>(k));
    }
    ASSERT_EQ(std::vector<JobId>(pool.queued().begin(), pool.queued().end()), ref) << "step " << step;
    ASSERT_EQ(pool.queued_demand(b), static_cast<int>(ref.size()));
    ASSERT_EQ(pool.queued_count(), ref.size());
    // Append numbers: increasing along the queue, -1 off it; queued_since(n) is the tail
    // of the queue numbered n or more.
    std::int64_t last = -1;
    for (JobId j : ref) {
      ASSERT_GT(pool.queue_number(j), last);
      last = pool.queue_number(j);
    }
    for (JobId j : out) ASSERT_EQ(pool.queue_number(j), -1);
    const std::int64_t n = ref.empty() ? 0 : pool.queue_number(ref[ref.size() / 2]);
    std::vector<JobId> tail;
    for (JobId j : ref)
      if (pool.queue_number(j) >= n) tail.push_back(j);
    ASSERT_EQ(std::vector<JobId>(pool.queued_since(n).begin(), pool.queued_since(n).end()), tail);
    ASSERT_TRUE(pool.queued_since(pool.appended()).begin() == pool.queued_since(pool.appended()).end());
  }
}

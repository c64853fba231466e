// GMB's plan cells (sched/policy/gmb/plan_cells.hpp): cells follow the racks and never
// join two; one cell plans exactly what the paper's flat GMB plans; with several cells
// every E-job of a plan runs in its job's home cell, a dry cell takes work from a loaded
// one, the schedule invariants (DESIGN.md) hold on random racked clusters, and the runtime
// loop plans only when a device enters the idle state.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "dcg_fixture.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/runtime/runtime_loop.hpp"

using namespace rayline;
using rayline::testing::check_schedule;

namespace {

// `nodes` nodes (disk, RAM, `cpus` threads) in racks of `rack` nodes on one 1 Gb/s LAN
// (a backbone between racks); rack <= 0: no racks.
DeviceGraph racked(int nodes, int rack, int cpus = 2) {
  std::string members, racks;
  for (int i = 0; i < nodes; ++i) {
    members += (i ? "," : "") + std::string(R"({"node": "n)") + std::to_string(i) + "\"";
    if (rack > 0) members += R"(, "rack": "r)" + std::to_string(i / rack) + "\"";
    members += "}";
  }
  for (int r = 0; rack > 0 && r * rack < nodes; ++r) racks += (r ? "," : "") + std::string(R"({"name": "r)") + std::to_string(r) + R"(", "uplink": "4Gb/s"})";
  std::string node_list;
  for (int i = 0; i < nodes; ++i) node_list += (i ? "," : "") + std::string(R"({"name": "n)") + std::to_string(i) + R"(", "type": "N"})";
  const std::string text = R"({"name": "cells", "node_types": {"N": {
      "memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"}, {"name": "ram", "kind": "host", "capacity": "2GB"}],
      "compute": [{"name": "cpu", "kind": "cpu", "count": )" + std::to_string(cpus) + R"(, "memory": "ram",
                   "timing": {"RayIntersect": {"setup": "5us", "rate": {"RayQueue": "32MB/s", "SceneData": "2GB/s"}}}}],
      "channels": [{"name": "sata", "kind": "sata", "between": ["disk", "ram"], "duplex": "half", "latency": "1ms", "bandwidth": "150MB/s"}]}},
    "nodes": [)" + node_list + R"(],
    "networks": [{"name": "lan", "latency": "100us", "duplex": "full", "bandwidth": "1Gb/s")" +
                           (rack > 0 ? R"(, "backbone": {"bandwidth": "10Gb/s"}, "racks": [)" + racks + "]" : std::string()) +
                           R"(, "members": [)" + members + "]}]}";
  return parse_platform(text, "cells.json");
}

// Scene blocks on every disk; each job traces one ray queue (in a random RAM, or all in
// `only_node`'s RAM when >= 0) against one scene block.
struct Work {
  JobPool pool;
  std::vector<std::pair<BlockId, MemId>> initial;
};
Work make_work(const DeviceGraph& g, std::mt19937& rng, int jobs, int only_node = -1) {
  Work w;
  std::vector<MemId> disks, rams;
  for (std::size_t m = 0; m < g.memories.size(); ++m)
    (g.memories[m].kind == MemoryKind::Disk ? disks : rams).push_back(static_cast<MemId>(m));
  std::vector<BlockId> scene;
  for (int i = 0; i < 6; ++i) {
    const BlockId b = w.pool.add_block({"scene" + std::to_string(i), DataKind::SceneData,
                                        Bytes(std::uniform_int_distribution<int>(20, 120)(rng)) * 1000000});
    scene.push_back(b);
    for (MemId d : disks) w.initial.emplace_back(b, d);
  }
  for (int i = 0; i < jobs; ++i) {
    DataBlock q{"rays" + std::to_string(i), DataKind::RayQueue, Bytes(std::uniform_int_distribution<int>(1, 20)(rng)) * 1000000};
    q.consumed = true;
    const BlockId sb = scene[std::uniform_int_distribution<std::size_t>(0, scene.size() - 1)(rng)];
    q.scene_block = sb;
    const BlockId qb = w.pool.add_block(q);
    const MemId at = only_node >= 0 ? rams[static_cast<std::size_t>(only_node)]
                                    : rams[std::uniform_int_distribution<std::size_t>(0, rams.size() - 1)(rng)];
    w.initial.emplace_back(qb, at);
    Job j;
    j.name = "j" + std::to_string(i);
    j.type = g.job_type("RayIntersect");
    j.inputs = {sb, qb};
    w.pool.add_job(std::move(j));
  }
  return w;
}

// Checks, after each plan, that every E-job it placed runs in its job's home cell.
class CellChecking final : public Scheduler {
 public:
  explicit CellChecking(GmbScheduler& gmb) : gmb_(gmb) {}
  std::string name() const override { return "cell-checking"; }
  bool plans_while_idle() const override { return while_idle < 0 ? gmb_.plans_while_idle() : while_idle > 0; }
  int while_idle = -1;  // -1: GMB's answer; 0 / 1: forced
  PlanStats plan(Time now, JobPool& pool, Schedule& s) override {
    const std::size_t before = s.activity_count();
    const PlanStats st = gmb_.plan(now, pool, s);
    moved += gmb_.cells().moved();
    for (std::size_t a = before; a < s.activity_count(); ++a) {
      const Activity& act = s.activity(static_cast<ActivityId>(a));
      if (act.kind != ActivityKind::Exec) continue;
      const std::int32_t home = gmb_.cells().home(act.job);
      const std::int32_t cell = gmb_.cells().cell_of_memory(s.graph().computes[static_cast<std::size_t>(act.device)].memory);
      if (home != kNone && home != cell) ++outside;
      ++execs;
    }
    return st;
  }
  int execs = 0, outside = 0;
  std::uint64_t moved = 0;

 private:
  GmbScheduler& gmb_;
};

struct Outcome {
  std::vector<std::tuple<int, JobId, DeviceId, ChannelId, BlockId, Time>> plan;  // every activity as committed
  RunStats stats;
  int execs = 0, outside = 0;
  std::uint64_t moved = 0;
  int cells = 0;
  std::vector<int> execs_per_cell;
};

Outcome run(const DeviceGraph& g, Work w, int cell_nodes, Time horizon = 0.5, int while_idle = -1) {
  Schedule s(g, w.pool);
  for (auto [b, m] : w.initial) s.put_initial(b, m);
  GmbScheduler gmb({.horizon = horizon, .cell_nodes = cell_nodes});
  CellChecking checking(gmb);
  checking.while_idle = while_idle;
  ExactExecutor ex(s);
  StaticWorkload wl;
  RuntimeLoop loop(checking, ex, wl, w.pool, s);
  Outcome o;
  o.stats = loop.run();
  for (const auto& e : check_schedule(s, w.pool).errors) ADD_FAILURE() << e;
  for (std::size_t j = 0; j < w.pool.job_count(); ++j)
    EXPECT_EQ(w.pool.state(static_cast<JobId>(j)), JobState::Done) << w.pool.job(static_cast<JobId>(j)).name;
  o.cells = gmb.cells().count();
  o.execs_per_cell.assign(static_cast<std::size_t>(o.cells), 0);
  for (std::size_t a = 0; a < s.activity_count(); ++a) {
    const Activity& act = s.activity(static_cast<ActivityId>(a));
    o.plan.emplace_back(static_cast<int>(act.kind), act.job, act.device, act.channel, act.block, act.planned_start);
    if (act.kind == ActivityKind::Exec)
      ++o.execs_per_cell[static_cast<std::size_t>(gmb.cells().cell_of_memory(g.computes[static_cast<std::size_t>(act.device)].memory))];
  }
  o.execs = checking.execs;
  o.outside = checking.outside;
  o.moved = checking.moved;
  return o;
}

}  // namespace

TEST(PlanCells, FollowRacksAndNeverJoinTwo) {
  PlanCells cells;
  // Racks of 5 cut into cells of at most 2 nodes: 2 + 2 + 1 per rack.
  const DeviceGraph g = racked(10, 5);
  cells.build(g, 2);
  EXPECT_EQ(cells.count(), 6);
  auto cell_of_node = [&](int n) { return cells.cell_of_memory(g.nodes[static_cast<std::size_t>(n)].memories[0]); };
  EXPECT_EQ(cell_of_node(0), cell_of_node(1));
  EXPECT_NE(cell_of_node(1), cell_of_node(2));
  EXPECT_NE(cell_of_node(4), cell_of_node(5));  // the last node of rack 0 is alone
  for (const Node& n : g.nodes)
    for (MemId m : n.memories) EXPECT_EQ(cells.cell_of_memory(m), cells.cell_of_memory(n.memories[0])) << n.name;
  // Without racks: consecutive nodes; a platform no larger than a cell is one cell.
  cells.build(racked(7, 0), 3);
  EXPECT_EQ(cells.count(), 3);
  cells.build(racked(9, 4), 8);
  EXPECT_EQ(cells.count(), 3) << "a cell never spans two racks";
  cells.build(racked(8, 4), 8);
  EXPECT_TRUE(cells.flat()) << "a platform no larger than a cell is planned whole";
  cells.build(racked(8, 0), 0);
  EXPECT_TRUE(cells.flat());
}

// One cell is the paper's GMB: the same activities, bit for bit, as cell_nodes = 0.
TEST(PlanCells, OneCellPlansExactlyAsFlatGmb) {
  for (int seed = 0; seed < 6; ++seed) {
    std::mt19937 rng(seed);
    const DeviceGraph g = racked(6, seed % 2 ? 3 : 0);
    std::mt19937 r1 = rng, r2 = rng;
    const Outcome flat = run(g, make_work(g, r1, 40), 0);
    const Outcome one = run(g, make_work(g, r2, 40), 6);
    EXPECT_EQ(one.cells, 1);
    EXPECT_EQ(flat.plan, one.plan) << "seed " << seed;
    EXPECT_EQ(flat.stats.makespan, one.stats.makespan);
  }
}

// Random racked clusters planned in cells: invariants hold, every job runs once, and
// every E-job runs in the cell its plan's cluster-level pass gave the job.
TEST(PlanCells, InvariantsAndHomeCellsOnRandomClusters) {
  int execs = 0;
  for (int seed = 0; seed < 24; ++seed) {
    std::mt19937 rng(100 + seed);
    const int nodes = std::uniform_int_distribution<int>(4, 9)(rng);
    const int rack = std::uniform_int_distribution<int>(0, 4)(rng);
    const int cell = std::uniform_int_distribution<int>(1, 3)(rng);
    const DeviceGraph g = racked(nodes, rack, std::uniform_int_distribution<int>(1, 3)(rng));
    const Time horizon = std::array<Time, 3>{0.05, 0.5, 5.0}[seed % 3];
    const Outcome o = run(g, make_work(g, rng, std::uniform_int_distribution<int>(10, 80)(rng)), cell, horizon);
    ASSERT_FALSE(o.stats.stalled) << "seed " << seed;
    EXPECT_GT(o.cells, 1) << "seed " << seed;
    EXPECT_EQ(o.outside, 0) << "seed " << seed << ": E-jobs planned outside their home cell";
    execs += o.execs;
    if (HasFailure()) return;
  }
  EXPECT_GT(execs, 500);
}

// Every ray queue starts on node 0: its cell alone would do all the work. The cluster
// pass moves jobs to the dry cells, so every cell runs some, and the makespan beats one
// cell's work alone.
TEST(PlanCells, DryCellsTakeWorkFromALoadedOne) {
  std::mt19937 rng(7);
  const DeviceGraph g = racked(8, 4);
  std::mt19937 r1 = rng, r2 = rng;
  const Outcome cells = run(g, make_work(g, r1, 200, 0), 2);
  EXPECT_EQ(cells.cells, 4);
  EXPECT_GT(cells.moved, 0u);
  for (std::size_t c = 0; c < cells.execs_per_cell.size(); ++c) EXPECT_GT(cells.execs_per_cell[c], 0) << "cell " << c;
  // Without moves (one cell of 2 nodes doing everything) it would take at least the
  // queues' tracing time on that cell's 4 threads.
  Work w = make_work(g, r2, 200, 0);
  double trace = 0;
  for (std::size_t j = 0; j < w.pool.job_count(); ++j) {
    Bytes q = 0;
    for (BlockId b : w.pool.job(static_cast<JobId>(j)).inputs)
      if (w.pool.block(b).kind == DataKind::RayQueue) q += w.pool.block(b).bytes;
    trace += static_cast<double>(q) / 32e6;
  }
  EXPECT_LT(cells.stats.makespan, trace / 4);
}

// In plan cells the loop plans only when a device enters the idle state (or new jobs
// arrive while one is idle), not at every batch of events while some device stays idle:
// every plan after the first follows an E-job's end, the run still completes every job
// with the invariants, in no more plans than the every-batch rule (far fewer where all ray
// queues start on one node and the other cells wait for moved work), and within 10 % of
// its makespan on these clusters.
TEST(PlanCells, PlansOnlyWhenADeviceEntersIdle) {
  int fewer = 0;
  for (int seed = 0; seed < 8; ++seed) {
    std::mt19937 rng(300 + seed), rng2(300 + seed);
    const DeviceGraph g = racked(8, 2, 2);
    // (Every ray queue on one node: the other cells' devices wait for moved work.)
    const Outcome events = run(g, make_work(g, rng, 120, seed % 2 ? 0 : -1), 2, 0.5, 0);
    const Outcome batches = run(g, make_work(g, rng2, 120, seed % 2 ? 0 : -1), 2, 0.5, 1);
    ASSERT_FALSE(events.stats.stalled) << "seed " << seed;
    EXPECT_LE(events.stats.plan_calls, events.execs + 1) << "seed " << seed;
    EXPECT_LE(events.stats.plan_calls, batches.stats.plan_calls) << "seed " << seed;
    fewer += events.stats.plan_calls < batches.stats.plan_calls;
    EXPECT_LT(events.stats.makespan, 1.1 * batches.stats.makespan) << "seed " << seed;
  }
  EXPECT_GE(fewer, 4) << "the concentrated cases (odd seeds) plan less often";
}

// The simulated twin of a render (workload/render_twin.hpp) over random ray logs: run under
// GMB and the exact executor on a workstation DCG whose RAM holds only part of the scene,
// every visit of the log is traced exactly once, every camera path ends, jobs respect the
// batching bounds and the schedule keeps its invariants. The ray-log file format
// (workload/ray_log.hpp): a round trip, and every malformed file rejected with the field named.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <array>
#include <random>
#include <string>

#include "common/error.hpp"
#include "sched/dcg_fixture.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/policy/scheduler_factory.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "workload/ray_log.hpp"
#include "workload/render_twin.hpp"

using namespace rayline;

namespace {

// A workstation as `rayline render` drives it: disk, RAM of `ram` bytes, two CPU threads.
DeviceGraph workstation(Bytes ram) {
  const std::string json = R"({"name": "w", "node_types": {"W": {
    "memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"},
               {"name": "ram", "kind": "host", "capacity": ")" + std::to_string(ram) + R"(B"}],
    "compute": [{"name": "cpu", "kind": "cpu", "count": 2, "memory": "ram",
      "timing": {"RayIntersect": {"setup": "50us", "rate": {"RayQueue": "64MB/s"}},
                 "ShadowIntersect": {"setup": "50us", "rate": {"ShadowRayQueue": "128MB/s"}}}}],
    "channels": [{"name": "disk", "kind": "disk", "between": ["disk", "ram"], "duplex": "half",
                  "latency": "1ms", "bandwidth": "150MB/s"}]}},
    "nodes": [{"name": "W", "type": "W"}]})";
  return parse_platform(json, "workstation");
}

// A random log: camera rays enter a random cell or miss; each visit hands on 0-2 rays
// (a miss: the same ray to another cell; a hit: a shadow ray and a continuation), up to
// `depth` bounces. Children always get larger ids than their parent, as a recording does.
RayLog random_log(std::uint32_t cells, std::uint32_t w, std::uint32_t h, std::uint32_t spp, int depth, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  RayLog log;
  log.width = w, log.height = h, log.spp = spp, log.cells = cells;
  std::uniform_int_distribution<std::uint32_t> cell(0, cells - 1);
  std::uniform_real_distribution<double> u(0, 1);
  log.entry.assign(std::size_t(w) * h * spp, RayLog::kNoVisit);
  struct Pending {
    std::uint32_t visit;
  };
  for (auto& e : log.entry) {
    if (u(rng) < 0.1) continue;  // missed the scene
    e = static_cast<std::uint32_t>(log.visits.size());
    log.visits.push_back({cell(rng), 0, 0, 0, 0});
    // Expand this path depth-first in id order: each visit's children right after it.
    for (std::size_t v = e; v < log.visits.size(); ++v) {
      RayVisit& rv = log.visits[v];
      std::vector<RayVisit> kids;
      const double x = u(rng);
      if (rv.kind == 1) {  // shadow: on to another cell, or ends (occluded / reaches the light)
        if (x < 0.3) kids.push_back({cell(rng), 0, rv.bounce, 1, 0});
      } else if (x < 0.35) {  // miss: on to another cell
        kids.push_back({cell(rng), 0, rv.bounce, 0, 0});
      } else if (x < 0.85 && rv.bounce + 1 < depth) {  // hit: shadow ray and continuation
        kids.push_back({cell(rng), 0, std::uint16_t(rv.bounce + 1), 1, 0});
        kids.push_back({cell(rng), 0, std::uint16_t(rv.bounce + 1), 0, 0});
      }
      log.visits[v].first = static_cast<std::uint32_t>(log.children.size());
      log.visits[v].children = static_cast<std::uint8_t>(kids.size());
      for (const RayVisit& k : kids) {
        log.children.push_back(static_cast<std::uint32_t>(log.visits.size()));
        log.visits.push_back(k);
      }
    }
  }
  return log;
}

// One SceneData block of 1 MB per cell, on the disk (memory 0).
std::vector<BlockId> scene_blocks(std::uint32_t cells, JobPool& pool, Schedule& s) {
  std::vector<BlockId> blocks;
  for (std::uint32_t c = 0; c < cells; ++c) {
    DataBlock d;
    d.name = "scene" + std::to_string(c);
    d.kind = DataKind::SceneData;
    d.bytes = 1'000'000;
    blocks.push_back(pool.add_block(d));
    s.put_initial(blocks.back(), 0, 0, true);
  }
  return blocks;
}

std::string temp_file(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("rayline-twin-" + std::to_string(::getpid()) + "-" + name)).string();
}

}  // namespace

TEST(RenderTwin, EveryVisitTracedOnceEveryPathEndsOnRandomLogs) {
  for (std::uint64_t seed = 1; seed <= 4; ++seed)
    for (const char* policy : {"gmb", "gmb-ca", "budge", "loadanyonce", "rayline"}) {
      SCOPED_TRACE(std::string(policy) + ", seed " + std::to_string(seed));
      const std::uint32_t cells = 3 + static_cast<std::uint32_t>(seed % 5);
      auto log = std::make_shared<RayLog>(random_log(cells, 24, 16, 2, 5, seed));
      // Blocks of 1 MB; RAM for a third of them plus the rays' room.
      const DeviceGraph g = workstation(Bytes(cells / 3 + 1) * 1'000'000 + Bytes(2'000'000));
      JobPool pool;
      Schedule s(g, pool);
      const std::vector<BlockId> blocks = scene_blocks(cells, pool, s);
      RayBatchOptions o;
      o.spp = 2;
      o.path_cap = 200;
      o.min_batch = 16;
      o.max_batch = 64;
      RenderTwinWorkload wl(g, 1, blocks, o, std::make_unique<ReplayOracle>(log));
      auto sched = make_scheduler(policy, 2.0);
      ExactExecutor ex(s);
      RuntimeLoop loop(*sched, ex, wl, pool, s);
      const RunStats st = loop.run();
      ASSERT_FALSE(st.stalled);
      EXPECT_TRUE(wl.finished());
      EXPECT_EQ(wl.counts().traced, log->visits.size());
      EXPECT_EQ(wl.counts().paths_ended, log->camera_rays());
      std::uint64_t leaves = 0;
      for (const RayVisit& v : log->visits) leaves += v.children == 0;
      EXPECT_EQ(wl.counts().ended_here, leaves);
      std::uint64_t loads = 0;
      for (std::size_t j = 0; j < pool.job_count(); ++j) {
        EXPECT_EQ(pool.state(static_cast<JobId>(j)), JobState::Done);
        EXPECT_LE(pool.job(static_cast<JobId>(j)).work, o.max_batch);
      }
      for (std::size_t i = 0; i < s.activity_count(); ++i) {
        const Activity& a = s.activity(static_cast<ActivityId>(i));
        loads += a.kind == ActivityKind::Transfer && pool.block(a.block).kind == DataKind::SceneData;
      }
      EXPECT_GT(loads, cells) << "RAM holds a third of the scene: some block must be loaded twice";
      const auto c = rayline::testing::check_schedule(s, pool);
      for (const auto& e : c.errors) ADD_FAILURE() << e;
    }
}

// The renderer's two in-job shortcuts, in the twin: rays continuing in their job's cell
// and, with one cell, jobs that make their own camera rays. Every visit is still traced
// once and every path ends; continuing takes fewer jobs; with both, in one cell, no ray
// ever waits in a queue: every job's only input is the scene block.
TEST(RenderTwin, ContinuationAndCameraJobsTraceEveryVisitOnce) {
  for (const std::uint32_t cells : {1u, 4u}) {
    auto log = std::make_shared<RayLog>(random_log(cells, 24, 16, 2, 5, 11));
    std::uint64_t leaves = 0;
    for (const RayVisit& v : log->visits) leaves += v.children == 0;
    std::size_t jobs[2][2] = {};
    for (const bool stay : {false, true})
      for (const bool camera : {false, true}) {
        SCOPED_TRACE(std::to_string(cells) + " cells, continue " + std::to_string(stay) + ", camera jobs " +
                     std::to_string(camera));
        const DeviceGraph g = workstation(Bytes(cells) * 1'000'000 + Bytes(2'000'000));
        JobPool pool;
        Schedule s(g, pool);
        const std::vector<BlockId> blocks = scene_blocks(cells, pool, s);
        RayBatchOptions o;
        o.spp = 2, o.path_cap = 200, o.min_batch = 16, o.max_batch = 64;
        o.continue_in_cell = stay, o.camera_jobs = camera;
        RenderTwinWorkload wl(g, 1, blocks, o, std::make_unique<ReplayOracle>(log));
        EXPECT_EQ(wl.options().camera_jobs, camera && cells == 1);
        auto sched = make_scheduler("gmb", 2.0);
        ExactExecutor ex(s);
        RuntimeLoop loop(*sched, ex, wl, pool, s);
        ASSERT_FALSE(loop.run().stalled);
        EXPECT_EQ(wl.counts().traced, log->visits.size());
        EXPECT_EQ(wl.counts().paths_ended, log->camera_rays());
        EXPECT_EQ(wl.counts().ended_here, leaves);
        for (std::size_t j = 0; j < pool.job_count(); ++j) {
          EXPECT_EQ(pool.state(static_cast<JobId>(j)), JobState::Done);
          if (wl.options().camera_jobs && stay) {
            EXPECT_EQ(pool.job(static_cast<JobId>(j)).inputs.size(), 1u);
          }
        }
        jobs[stay][camera] = pool.job_count();
        const auto c = rayline::testing::check_schedule(s, pool);
        for (const auto& e : c.errors) ADD_FAILURE() << e;
      }
    if (cells == 1) {
      EXPECT_LT(jobs[1][0], jobs[0][0]) << "in one cell, continuing leaves no ray for another job";
    }
  }
}

// The Markov oracle: per (cell, kind, bounce) outcome statistics of a log, sampled per ray.
// Every path still ends; the visits per camera ray, the visits per cell and the entry
// cells per tile match the log's within sampling noise; and it describes the scene at
// another resolution and spp too.
TEST(RenderTwin, MarkovOracleReproducesTheLogsStatistics) {
  const RayLog log = random_log(6, 64, 48, 4, 5, 11);
  for (const auto [w, h, spp] : {std::array<std::uint32_t, 3>{64, 48, 4}, std::array<std::uint32_t, 3>{128, 96, 2}}) {
    MarkovOracle m(log, w, h, spp, 5);
    EXPECT_EQ(m.camera_rays(), std::uint64_t(w) * h * spp);
    std::vector<double> per_cell(6, 0.0), log_cell(6, 0.0);
    for (const RayVisit& v : log.visits) log_cell[v.cell] += 1.0 / double(log.camera_rays());
    std::uint64_t visits = 0, entered = 0;
    std::vector<TwinRay> stack, out;
    for (std::uint64_t i = 0; i < m.camera_rays(); ++i) {
      TwinRay r;
      if (!m.entry(i, r)) continue;
      ++entered;
      stack.assign(1, r);
      while (!stack.empty()) {
        const TwinRay x = stack.back();
        stack.pop_back();
        ++visits;
        per_cell[x.cell] += 1.0 / double(m.camera_rays());
        out.clear();
        m.visit(x, out);
        ASSERT_LE(out.size(), 2u);
        for (const TwinRay& y : out) {
          ASSERT_LT(y.cell, 6u);
          ASSERT_LT(y.bounce, 5u) << "no ray beyond the log's path length";
          stack.push_back(y);
        }
      }
    }
    std::uint64_t log_entered = 0;
    for (std::uint32_t e : log.entry) log_entered += e != RayLog::kNoVisit;
    const double per_ray = double(visits) / double(m.camera_rays()), log_per_ray = double(log.visits.size()) / double(log.camera_rays());
    EXPECT_NEAR(per_ray, log_per_ray, 0.05 * log_per_ray);
    EXPECT_NEAR(double(entered) / double(m.camera_rays()), double(log_entered) / double(log.camera_rays()), 0.02);
    for (std::size_t c = 0; c < 6; ++c) EXPECT_NEAR(per_cell[c], log_cell[c], 0.1 * log_cell[c]) << "cell " << c;
  }
}

TEST(RayLogFile, RoundTripKeepsEveryRecord) {
  const RayLog log = random_log(7, 9, 5, 3, 5, 42);
  const std::string f = temp_file("roundtrip.rays");
  log.save(f);
  const RayLog back = RayLog::load(f);
  std::remove(f.c_str());
  EXPECT_EQ(back.width, 9u);
  EXPECT_EQ(back.cells, 7u);
  EXPECT_EQ(back.entry, log.entry);
  EXPECT_EQ(back.children, log.children);
  ASSERT_EQ(back.visits.size(), log.visits.size());
  for (std::size_t i = 0; i < log.visits.size(); ++i) {
    EXPECT_EQ(back.visits[i].cell, log.visits[i].cell);
    EXPECT_EQ(back.visits[i].first, log.visits[i].first);
    EXPECT_EQ(back.visits[i].bounce, log.visits[i].bounce);
    EXPECT_EQ(back.visits[i].kind, log.visits[i].kind);
    EXPECT_EQ(back.visits[i].children, log.visits[i].children);
  }
}

TEST(RayLogFile, MalformedFilesNameTheField) {
  const RayLog good = random_log(4, 4, 4, 1, 4, 7);
  ASSERT_GT(good.children.size(), 0u);
  const auto expect_error = [](const RayLog& log, const std::string& field, const std::string& name) {
    const std::string f = temp_file(name);
    log.save(f);
    try {
      (void)RayLog::load(f);
      ADD_FAILURE() << name << ": accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), field) << name << ": " << e.what();
      EXPECT_EQ(e.file(), f);
    }
    std::remove(f.c_str());
  };
  RayLog bad = good;
  bad.visits[0].cell = 4;
  expect_error(bad, "visits.cell", "cell.rays");
  bad = good;
  bad.children[0] = 0;  // handed back to the first visit: a cycle
  expect_error(bad, "children", "cycle.rays");
  bad = good;
  bad.children[0] = static_cast<std::uint32_t>(good.visits.size());
  expect_error(bad, "children", "child.rays");
  bad = good;
  bad.visits[0].kind = 2;
  expect_error(bad, "visits.kind", "kind.rays");
  bad = good;
  bad.entry.pop_back();  // width x height x spp no longer the camera rays
  expect_error(bad, "camera rays", "count.rays");
  // Truncated, and not a ray log at all.
  const std::string f = temp_file("cut.rays");
  good.save(f);
  std::filesystem::resize_file(f, std::filesystem::file_size(f) - 3);
  EXPECT_THROW((void)RayLog::load(f), InputError);
  {
    std::ofstream out(f, std::ios::trunc);
    out << "{\"not\": \"a ray log\"}";
  }
  try {
    (void)RayLog::load(f);
    ADD_FAILURE() << "a JSON file accepted as a ray log";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "header");
  }
  std::remove(f.c_str());
}

// The synthetic ray-batching stream under GMB and the exact executor: conservation (every
// ray that was generated or spawned is traced exactly once once the stream drains), queue
// merging, determinism for a seed, and the schedule invariants on a dynamic workload.
#include <gtest/gtest.h>

#include "sched/dcg_fixture.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "workload/ray_stream.hpp"
#include "sched/runtime/runtime_loop.hpp"

using namespace rayline;

namespace {

struct Outcome {
  std::uint64_t traced, primary, spawned, merges;
  Time makespan;
  std::size_t activities;
};

RayStreamOptions stream_options(std::uint64_t seed) {
  RayStreamOptions o;
  o.blocks = 12;
  o.scene_bytes = Bytes(12) * 100'000'000;  // 100 MB blocks
  o.rays_min = 2e4;
  o.rays_max = 2e5;
  o.stop_new_batches = 8.0;
  o.seed = seed;
  return o;
}

// Runs the stream to exhaustion under GMB and the exact executor; every job must finish.
Outcome run_stream(const RayStreamOptions& o, bool check) {
  const DeviceGraph g = rayline::testing::three_node_stream_cluster();
  JobPool pool;
  Schedule s(g, pool);
  RayStreamWorkload wl(g, o);
  GmbScheduler gmb({.horizon = 2.0});
  ExactExecutor ex(s);
  RuntimeLoop loop(gmb, ex, wl, pool, s);
  const RunStats st = loop.run();
  EXPECT_FALSE(st.stalled);
  EXPECT_EQ(pool.queued_count(), 0u);
  for (std::size_t j = 0; j < pool.job_count(); ++j) EXPECT_EQ(pool.state(static_cast<JobId>(j)), JobState::Done);
  if (check) {
    const auto c = rayline::testing::check_schedule(s, pool);
    for (const auto& e : c.errors) ADD_FAILURE() << e;
  }
  return {wl.rays_traced(), wl.primary_rays(), wl.spawned_rays(), wl.merges(), st.makespan, s.activity_count()};
}
}  // namespace

TEST(RayStream, ConservesRaysMergesQueuesAndKeepsInvariants) {
  const Outcome o = run_stream(stream_options(3), true);
  EXPECT_GT(o.primary, 0u);
  EXPECT_GT(o.spawned, 0u);
  EXPECT_GT(o.merges, 0u) << "queues produced where a queued job holds one must merge";
  EXPECT_EQ(o.traced, o.primary + o.spawned);
  EXPECT_GT(o.makespan, 8.0);
  std::printf("[ray-stream] %llu rays traced (%llu primary + %llu spawned), %llu merges, %zu activities, %.2f s\n",
              static_cast<unsigned long long>(o.traced), static_cast<unsigned long long>(o.primary),
              static_cast<unsigned long long>(o.spawned), static_cast<unsigned long long>(o.merges), o.activities, o.makespan);
}

TEST(RayStream, DeterministicForASeed) {
  const Outcome a = run_stream(stream_options(11), false), b = run_stream(stream_options(11), false),
                c = run_stream(stream_options(12), false);
  EXPECT_EQ(a.traced, b.traced);
  EXPECT_EQ(a.activities, b.activities);
  EXPECT_DOUBLE_EQ(a.makespan, b.makespan);
  EXPECT_NE(a.traced, c.traced);
}

// Few blocks mean few distinct queues: new batches merge instead of adding jobs, and the
// stream must still make progress (it used to spin trying to reach its backlog).
TEST(RayStream, OneBlockSceneMergesInsteadOfSpinning) {
  RayStreamOptions o = stream_options(1);
  o.blocks = 1;
  o.scene_bytes = 100'000'000;
  o.stop_new_batches = 2.0;
  const Outcome r = run_stream(o, true);
  EXPECT_GT(r.merges, 0u);
  EXPECT_EQ(r.traced, r.primary + r.spawned);
}

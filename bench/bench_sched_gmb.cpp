// GMB planning speed: placements per second and wall time to plan a full 2 s
// horizon on the paper cluster with 129 scene blocks and 1 000 queued RayIntersect jobs.
// A placement is one committed E-job or T-job. Run: build/bench/bench_sched_gmb
// The *_reference cases plan the same instances with GmbOptions::reference_selection (the
// straightforward pruned scan, same choices: test_gmb_equivalence) for a side-by-side.
// Cold cases construct a new GmbScheduler for every plan; the *_warm cases keep one
// GmbScheduler across iterations (as the runtime loop keeps it across plan calls), each
// iteration planning a fresh Schedule of the same instance, so its buffers are reused.
#include <benchmark/benchmark.h>

#include <optional>

#include "bench/gmb_bench_instance.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/io/platform_loader.hpp"

using namespace rayline;

namespace {

void plan_horizon(benchmark::State& state, const char* platform, int blocks, int jobs, Time horizon,
                  bool reference = false, bool warm = false) {
  const DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/" + platform);
  const JobSet base = bench::gmb_bench_jobs(g, blocks, jobs);
  double placements = 0, execs = 0, searches = 0, hits = 0, cut = 0, plan_seconds = 0;
  const GmbOptions opt{.horizon = horizon, .reference_selection = reference};
  GmbScheduler kept(opt);
  for (auto _ : state) {
    state.PauseTiming();
    auto [set, s] = bench::fresh_plan(g, base);
    std::optional<GmbScheduler> fresh;
    if (!warm) fresh.emplace(opt);
    GmbScheduler& gmb = warm ? kept : *fresh;
    state.ResumeTiming();
    const PlanStats st = gmb.plan(0, set->pool, *s);
    benchmark::DoNotOptimize(st);
    state.PauseTiming();
    placements += st.execs + st.transfers;
    execs += st.execs;
    const GmbSearchStats& sdc = gmb.last_search_stats();
    searches += static_cast<double>(sdc.path_searches);
    hits += static_cast<double>(sdc.path_cache_hits);
    cut += static_cast<double>(sdc.path_cut_searches);
    plan_seconds += st.wall_seconds;
    // Teardown untimed too (the timed region is plan() alone).
    s.reset();
    fresh.reset();
    set.reset();
    state.ResumeTiming();
  }
  state.counters["placements/s"] = benchmark::Counter(placements, benchmark::Counter::kIsRate);
  state.counters["placements"] = benchmark::Counter(placements, benchmark::Counter::kAvgIterations);
  state.counters["E-jobs"] = benchmark::Counter(execs, benchmark::Counter::kAvgIterations);
  state.counters["sdc_searches"] = benchmark::Counter(searches, benchmark::Counter::kAvgIterations);
  state.counters["sdc_cut_searches"] = benchmark::Counter(cut, benchmark::Counter::kAvgIterations);
  state.counters["sdc_cache_hit%"] = hits + searches > 0 ? 100 * hits / (hits + searches) : 0;
  state.counters["plan_ms"] = benchmark::Counter(plan_seconds * 1e3, benchmark::Counter::kAvgIterations);
}

void BM_GmbPaperCluster_2s(benchmark::State& s) { plan_horizon(s, "paper-cluster.json", 129, 1000, 2.0); }
void BM_GmbPaperCluster_10s(benchmark::State& s) { plan_horizon(s, "paper-cluster.json", 129, 1000, 10.0); }
void BM_GmbPaperCluster_all(benchmark::State& s) { plan_horizon(s, "paper-cluster.json", 129, 1000, 1e9); }
void BM_GmbSingleNodeA_2s(benchmark::State& s) { plan_horizon(s, "paper-A.json", 129, 1000, 2.0); }
void BM_GmbPaperCluster_2s_warm(benchmark::State& s) { plan_horizon(s, "paper-cluster.json", 129, 1000, 2.0, false, true); }
void BM_GmbSingleNodeA_2s_warm(benchmark::State& s) { plan_horizon(s, "paper-A.json", 129, 1000, 2.0, false, true); }
void BM_GmbPaperCluster_2s_reference(benchmark::State& s) { plan_horizon(s, "paper-cluster.json", 129, 1000, 2.0, true); }
void BM_GmbPaperCluster_10s_reference(benchmark::State& s) { plan_horizon(s, "paper-cluster.json", 129, 1000, 10.0, true); }
void BM_GmbPaperCluster_all_reference(benchmark::State& s) { plan_horizon(s, "paper-cluster.json", 129, 1000, 1e9, true); }

}  // namespace

BENCHMARK(BM_GmbPaperCluster_2s)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GmbPaperCluster_10s)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GmbPaperCluster_all)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_GmbSingleNodeA_2s)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GmbPaperCluster_2s_warm)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GmbSingleNodeA_2s_warm)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GmbPaperCluster_2s_reference)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GmbPaperCluster_10s_reference)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GmbPaperCluster_all_reference)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK_MAIN();

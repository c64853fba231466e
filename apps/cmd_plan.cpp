// `rayline plan`: GMB over a static job set, executed in-process exactly as predicted
// (re-planning every time a device's timeline runs dry, Sec. 4.2), then summarised.
#include "apps/cmd_plan.hpp"

#include <algorithm>
#include <cstdio>
#include <map>

#include "apps/cli_common.hpp"
#include "apps/platform_path.hpp"
#include "common/error.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "workload/job_set.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "sched/io/trace_output.hpp"
#include "sched/policy/unplaced.hpp"
#include "common/units.hpp"
#include "sched/timeline/utilisation.hpp"

namespace rayline::cli {

int run_plan(const PlanOptions& opt) {
  Time horizon = 0;
  try {
    horizon = units::parse_duration(opt.horizon);
  } catch (const std::invalid_argument& e) {
    throw InputError("--horizon", "", e.what());
  }
  if (!(horizon > 0)) throw InputError("--horizon", "", "must be > 0");
  check_distinct({{"--trace", opt.trace}, {"--jobs-csv", opt.jobs_csv}},
                 {{"--platform", resolve_platform(opt.platform)}, {"--jobs", opt.jobs}});
  if (!opt.trace.empty()) check_output_file(opt.trace, "--trace", "out/plan.json");
  if (!opt.jobs_csv.empty()) check_output_file(opt.jobs_csv, "--jobs-csv", "out/plan.csv");
  const DeviceGraph g = load_platform(resolve_platform(opt.platform));
  JobSet set = opt.jobs.empty() ? synthetic_ray_batching(g, opt.synthetic_blocks, opt.synthetic_jobs, opt.seed)
                                : load_job_set(opt.jobs, g);
  Schedule s(g, set.pool);
  for (auto [b, m] : set.initial) s.put_initial(b, m);
  GmbScheduler gmb({.horizon = horizon});
  ExactExecutor ex(s);
  StaticWorkload wl;
  RuntimeLoop loop(gmb, ex, wl, set.pool, s);
  const RunStats st = loop.run();
  if (st.stalled) {
    std::fprintf(stderr, "rayline: %s\n", unplaced_summary(set.pool, s).c_str());
  }
  const Utilisation u = compute_utilisation(s, 0, st.makespan);
  if (!opt.trace.empty()) write_file_atomic(opt.trace, chrome_trace_json(s, false));
  if (!opt.jobs_csv.empty()) write_file_atomic(opt.jobs_csv, jobs_csv(s));

  double bytes_moved = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i)
    if (s.activity(static_cast<ActivityId>(i)).kind == ActivityKind::Transfer)
      bytes_moved += static_cast<double>(s.activity(static_cast<ActivityId>(i)).bytes);
  std::printf("platform %s: %zu nodes, %zu compute devices, %zu memory devices\n", g.name.c_str(), g.nodes.size(),
              g.computes.size(), g.memories.size());
  std::printf("jobs %zu  E-jobs %llu  T-jobs %llu  evictions %llu  moved %.3f GB  horizon k=%.3f s\n",
              set.pool.job_count(), static_cast<unsigned long long>(st.execs), static_cast<unsigned long long>(st.transfers),
              static_cast<unsigned long long>(st.evictions), bytes_moved / 1e9, horizon);
  std::printf("makespan %.3f s  plan calls %d  scheduler wall %.3f ms\n", st.makespan, st.plan_calls,
              st.scheduler_wall_seconds * 1e3);
  // Per kind of device: the paper's split of time (Sec. 4.2).
  std::map<std::string, DeviceTime> by_kind;
  std::map<std::string, int> count;
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const std::string k(to_string(g.computes[d].kind));
    DeviceTime& t = by_kind[k];
    t.busy += u.devices[d].busy;
    t.setup += u.devices[d].setup;
    t.fetching += u.devices[d].fetching;
    t.idle += u.devices[d].idle;
    ++count[k];
  }
  for (const auto& [k, t] : by_kind) {
    const double tot = std::max(1e-300, t.busy + t.setup + t.fetching + t.idle);
    std::printf("%-4s x%-3d busy %5.1f%%  setup %5.1f%%  fetching %5.1f%%  true idle %5.1f%%\n", k.c_str(), count[k],
                100 * t.busy / tot, 100 * t.setup / tot, 100 * t.fetching / tot, 100 * t.idle / tot);
  }
  if (!opt.quiet) {
    std::printf("\n%-16s %8s %8s %8s %8s %8s\n", "device", "util%", "busy s", "setup s", "fetch s", "idle s");
    for (std::size_t d = 0; d < g.computes.size(); ++d) {
      const DeviceTime& t = u.devices[d];
      std::printf("%-16s %8.1f %8.3f %8.4f %8.3f %8.3f\n", g.computes[d].name.c_str(), 100 * t.utilisation(u.span), t.busy,
                  t.setup, t.fetching, t.idle);
    }
    std::printf("\n%-22s %8s %10s\n", "resource", "busy%", "GB");
    for (std::size_t r = 0; r < g.resources.size(); ++r)
      if (u.resource_busy[r] > 0)
        std::printf("%-22s %8.1f %10.3f\n", g.resources[r].name.c_str(), 100 * u.resource_busy[r] / std::max(1e-300, u.span),
                    u.resource_bytes[r] / 1e9);
  }
  return st.stalled ? kExitFailure : kExitOk;
}

}  // namespace rayline::cli

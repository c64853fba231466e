// `rayline plan`: a static job set planned by one of the factory's schedulers (GMB by
// default), executed in-process exactly as predicted, then summarised.
#include "apps/cmd_plan.hpp"

#include <algorithm>
#include <cstdio>
#include <map>

#include "apps/cli_common.hpp"
#include "apps/platform_path.hpp"
#include "apps/run/exact_run.hpp"
#include "apps/run/run_options.hpp"
#include "common/error.hpp"
#include "sched/io/trace_output.hpp"
#include "sched/policy/unplaced.hpp"
#include "sched/timeline/utilisation.hpp"

namespace rayline::cli {

namespace {

// The flags checked before any work: the scheduler, the horizon, the outputs.
ExactRunOptions plan_options(const PlanOptions& opt) {
  ExactRunOptions o;
  const Time horizon = duration_flag("--horizon", opt.horizon);
  o.scheduler = scheduler_choice(opt.scheduler, horizon, parse_aging(opt.aging, "--aging"));
  o.platform_file = resolve_platform(opt.platform);
  o.jobs_file = opt.jobs;
  o.synthetic_blocks = opt.synthetic_blocks;
  o.synthetic_jobs = opt.synthetic_jobs;
  o.seed = opt.seed;
  check_distinct({{"--trace", opt.trace}, {"--jobs-csv", opt.jobs_csv}},
                 {{"--platform", resolve_platform(opt.platform)}, {"--jobs", opt.jobs}});
  if (!opt.trace.empty()) check_output_file(opt.trace, "--trace", "out/plan.json");
  if (!opt.jobs_csv.empty()) check_output_file(opt.jobs_csv, "--jobs-csv", "out/plan.csv");
  return o;
}

// Per kind of device: the paper's split of time (Sec. 4.2).
void print_kinds(const DeviceGraph& g, const Utilisation& u) {
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
}

// Per device and per busy resource (without --quiet).
void print_details(const DeviceGraph& g, const Utilisation& u) {
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

void print_summary(const ExactRun& p, const RunStats& st, Time horizon) {
  const DeviceGraph& g = p.graph();
  const Schedule& s = p.schedule();
  double bytes_moved = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i)
    if (s.activity(static_cast<ActivityId>(i)).kind == ActivityKind::Transfer)
      bytes_moved += static_cast<double>(s.activity(static_cast<ActivityId>(i)).bytes);
  std::printf("platform %s: %zu nodes, %zu compute devices, %zu memory devices\n", g.name.c_str(), g.nodes.size(),
              g.computes.size(), g.memories.size());
  std::printf("jobs %zu  E-jobs %llu  T-jobs %llu  evictions %llu  moved %s  horizon k=%s\n", p.pool().job_count(),
              static_cast<unsigned long long>(st.execs), static_cast<unsigned long long>(st.transfers),
              static_cast<unsigned long long>(st.evictions), format_size(bytes_moved).c_str(),
              format_duration(horizon).c_str());
  std::printf("makespan %s  plan calls %d  scheduler wall %s\n", format_duration(st.makespan).c_str(), st.plan_calls,
              format_duration(st.scheduler_wall_seconds).c_str());
}

}  // namespace

int run_plan(const PlanOptions& opt) {
  const ExactRunOptions o = plan_options(opt);
  ExactRun p(o);
  const RunStats st = p.run();
  if (st.stalled) {
    std::fprintf(stderr, "rayline: %s\n", unplaced_summary(p.pool(), p.schedule()).c_str());
  }
  const Utilisation u = compute_utilisation(p.schedule(), 0, st.makespan);
  if (!opt.trace.empty()) write_file_atomic(opt.trace, chrome_trace_json(p.schedule(), false));
  if (!opt.jobs_csv.empty()) write_file_atomic(opt.jobs_csv, jobs_csv(p.schedule()));
  print_summary(p, st, o.scheduler.horizon);
  print_kinds(p.graph(), u);
  if (!opt.quiet) print_details(p.graph(), u);
  return st.stalled ? kExitFailure : kExitOk;
}

}  // namespace rayline::cli

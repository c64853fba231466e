#include "apps/cmd_simulate.hpp"

#include <cstdio>
#include <unistd.h>

#include "apps/cli_common.hpp"
#include "apps/platform_path.hpp"
#include "sched/error.hpp"
#include "sched/units.hpp"
#include "sim/simulation.hpp"

namespace rayline::cli {

namespace {
double duration_flag(const std::string& flag, const std::string& text) {
  try {
    return units::parse_duration(text);
  } catch (const std::invalid_argument& e) {
    throw InputError(flag, "", e.what());
  }
}
}  // namespace

int run_simulate(const SimulateOptions& opt) {
  sim::SimulationConfig cfg;
  cfg.platform_file = resolve_platform(opt.platform);
  cfg.workload = opt.workload;
  cfg.scheduler = opt.scheduler;
  cfg.horizon = duration_flag("--horizon", opt.horizon);
  cfg.duration = duration_flag("--duration", opt.duration);
  cfg.seed = opt.seed;
  cfg.exec_noise = opt.exec_noise;
  cfg.blocks = opt.blocks;
  cfg.out_dir = opt.out;
  cfg.paje = opt.paje;
  cfg.progress = !opt.no_progress && ::isatty(2);
  const sim::SimulationSummary s = sim::run_simulation(cfg);
  std::printf("simulated %.3f s in %.3f s wall (%.0fx), %.4g rays/s, %llu activities, scheduler %.3f s (%.2f%% of simulated time)\n",
              s.simulated, s.wall_seconds, s.wall_seconds > 0 ? s.simulated / s.wall_seconds : 0.0, s.rays_per_second,
              static_cast<unsigned long long>(s.activities), s.scheduler_seconds,
              s.simulated > 0 ? 100 * s.scheduler_seconds / s.simulated : 0.0);
  std::printf("results: %s/metrics.json, jobs.csv, timeline.json\n", opt.out.c_str());
  if (s.stalled) {
    std::fprintf(stderr, "rayline: %zu queued job(s) could not be placed on any device (capacity or no path)\n",
                 s.queued_at_end);
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace rayline::cli

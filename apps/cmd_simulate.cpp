#include "apps/cmd_simulate.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include "apps/cli_common.hpp"
#include "apps/interrupt.hpp"
#include "apps/platform_path.hpp"
#include "common/error.hpp"
#include "common/units.hpp"
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

// "boeing" / "museum": the scene profiles in scenes/ (RAYLINE_SCENES overrides the folder).
std::string resolve_workload(const std::string& w) {
  namespace fs = std::filesystem;
  if (w != "boeing" && w != "museum") return w;
  const char* env = std::getenv("RAYLINE_SCENES");
  const fs::path dir = env ? fs::path(env) : fs::path(RAYLINE_PLATFORM_DIR) / ".." / "scenes";
  return (dir / (w + ".profile.json")).lexically_normal().string();
}

std::vector<int> client_counts(const std::string& text) {
  std::vector<int> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = text.find(',', pos);
    const std::string item = text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || *end != '\0' || v < 1 || v > 1023)
      throw InputError("--clients", "", "expected N or a list N1,N2,... of integers in [1, 1023], got '" + text + "'");
    out.push_back(static_cast<int>(v));
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return out;
}

void print_summary(const sim::SimulationSummary& s, const std::string& out, bool timeline) {
  std::printf("simulated %.3f s in %.3f s wall (%.0fx), %.4g rays/s, %llu activities, scheduler %.3f s (%.2f%% of simulated time)\n",
              s.simulated, s.wall_seconds, s.wall_seconds > 0 ? s.simulated / s.wall_seconds : 0.0, s.rays_per_second,
              static_cast<unsigned long long>(s.activities), s.scheduler_seconds,
              s.simulated > 0 ? 100 * s.scheduler_seconds / s.simulated : 0.0);
  if (s.path_trace) {
    std::printf("steady state: %.4g rays/s; frames delivered %llu; devices busy %.1f%%, setup %.1f%%, fetching %.1f%%, true idle %.1f%%\n",
                s.steady_rays_per_second, static_cast<unsigned long long>(s.frames_delivered), 100 * s.busy, 100 * s.setup,
                100 * s.fetching, 100 * s.idle);
    if (s.prediction_accuracy >= 0)
      std::printf("prediction accuracy %.1f%% (jobs), %.1f%% (rays)\n", 100 * s.prediction_accuracy,
                  100 * s.prediction_ray_accuracy);
  }
  std::printf("results: %s/metrics.json, jobs.csv%s\n", out.c_str(), timeline ? ", timeline.json" : "");
}
}  // namespace

namespace {
// The flags as a SimulationConfig (clients left at 1): every text flag parsed, InputError
// naming the flag otherwise.
sim::SimulationConfig simulate_config(const SimulateOptions& opt) {
  sim::SimulationConfig cfg;
  cfg.platform_file = resolve_platform(opt.platform);
  cfg.workload = resolve_workload(opt.workload);
  cfg.scheduler = opt.scheduler;
  cfg.horizon = duration_flag("--horizon", opt.horizon);
  const AgingSetting aging = parse_aging(opt.aging, "--aging");
  cfg.aging = aging.aging;
  cfg.adaptive_aging = aging.adaptive;
  cfg.duration = duration_flag("--duration", opt.duration);
  cfg.seed = opt.seed;
  cfg.exec_noise = opt.exec_noise;
  cfg.transfer_order = opt.transfer_order;
  cfg.blocks = opt.blocks;
  cfg.out_dir = opt.out;
  cfg.paje = opt.paje;
  cfg.timeline = !opt.no_timeline;
  cfg.progress = ProgressLine::for_stderr(opt.no_progress);
  cfg.prediction_depth = opt.prediction_depth;
  cfg.merge_planned = opt.merge_planned == "on";
  cfg.cancel_failed = opt.cancel_failed == "on";
  cfg.retime_merged = opt.retime_merged == "on";
  cfg.fidelity = opt.fidelity;
  cfg.replay_file = opt.replay;
  cfg.record_replay = opt.record_replay;
  if (!opt.warmup.empty()) cfg.warmup = duration_flag("--warmup", opt.warmup);
  // The path-tracing flags (Sec. 5-6) mean nothing to a ray stream or a job set: a run
  // that silently ignored one would not be the run the user asked for.
  if (!cfg.workload.ends_with(".profile.json")) {
    const std::vector<int> counts = client_counts(opt.clients);
    std::string given;
    int n = 0;
    const auto flag = [&given, &n](bool set, const char* name) {
      if (set) given += (n++ ? ", " : "") + std::string(name);
    };
    flag(counts.size() > 1 || counts[0] != 1, "--clients");
    flag(opt.prediction_depth != 0, "--prediction-depth");
    flag(opt.fidelity != "markov", "--fidelity");
    flag(!opt.replay.empty(), "--replay");
    flag(opt.record_replay, "--record-replay");
    flag(!opt.warmup.empty(), "--warmup");
    flag(opt.merge_planned != "on", "--merge-planned");
    flag(opt.retime_merged != "on", "--retime-merged");
    flag(opt.cancel_failed != "on", "--cancel-failed");
    if (!given.empty())
      throw InputError("--workload", "", given + (n == 1 ? " applies" : " apply") + " only to path tracing (--workload boeing, museum or "
                                         "FILE.profile.json), not to '" + opt.workload + "'");
  }
  // --blocks sizes the synthetic ray stream's scene; a job set and a scene profile bring their own.
  if (cfg.workload != "ray-stream" && opt.blocks != SimulateOptions{}.blocks)
    throw InputError("--blocks", "", "applies only to the ray stream (--workload ray-stream): '" + opt.workload +
                                         "' brings its own blocks");
  return cfg;
}
}  // namespace

void check_simulate_flags(const SimulateOptions& opt) { simulate_config(opt); }

void check_run_folder(const SimulateOptions& opt, const std::string& dir) {
  sim::check_results_folder(dir, "--out");
  const std::string workload = resolve_workload(opt.workload);
  check_not_inside(dir, "--out",
                   {{"--platform", resolve_platform(opt.platform)},
                    {"--workload", workload == "ray-stream" ? "" : workload},
                    {"--replay", opt.replay}});
}

int run_simulate(const SimulateOptions& opt) {
  sim::SimulationConfig cfg = simulate_config(opt);
  const std::vector<int> counts = client_counts(opt.clients);
  // Before any run: a folder holding the user's files is never replaced, nor one an input lies in.
  for (int n : counts) check_run_folder(opt, counts.size() == 1 ? opt.out : opt.out + "/clients-" + std::to_string(n));
  if (counts.size() == 1) {
    cfg.clients = counts[0];
    const sim::SimulationSummary s = sim::run_simulation(cfg);
    print_summary(s, opt.out, cfg.timeline);
    if (s.stalled) {
      std::fprintf(stderr, "rayline: %s\n", s.stalled_reason.c_str());
      return kExitFailure;
    }
    return kExitOk;
  }
  // A sweep (Sec. 6: "we increase the number of clients until each method reaches its peak
  // performance"): one process per point (SimGrid's engine is a process-wide singleton),
  // results in OUT/clients-N/; the summary line of each and the peak.
  double peak = 0;
  int peak_n = 0;
  std::printf("clients,steady_rays_per_second,prediction_accuracy,busy,setup,fetching,idle,frames\n");
  std::fflush(stdout);
  for (int n : counts) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
      interrupt_cleanup_after_fork();
      ::close(fds[0]);
      int rc = kExitFailure;
      try {
        sim::SimulationConfig c = cfg;
        c.clients = n;
        c.out_dir = opt.out + "/clients-" + std::to_string(n);
        c.progress = ProgressLine::Mode::Off;
        const sim::SimulationSummary s = sim::run_simulation(c);
        char line[512];
        const int len = std::snprintf(line, sizeof line, "%d,%.6g,%.4f,%.4f,%.4f,%.4f,%.4f,%llu\n", n,
                                      s.steady_rays_per_second, s.prediction_accuracy, s.busy, s.setup, s.fetching, s.idle,
                                      static_cast<unsigned long long>(s.frames_delivered));
        if (::write(fds[1], line, static_cast<std::size_t>(len)) != len) rc = kExitFailure;
        else rc = s.stalled ? kExitFailure : kExitOk;
      } catch (const InputError& e) {
        std::fprintf(stderr, "rayline: %s\n", e.what());
        rc = kExitBadInput;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "rayline: %s\n", e.what());
      }
      ::close(fds[1]);
      std::fflush(nullptr);
      ::_exit(rc);
    }
    add_child(pid);  // an interrupt stops it, and it removes its unfinished outputs
    ::close(fds[1]);
    std::string line;
    char buf[512];
    for (ssize_t k; (k = ::read(fds[0], buf, sizeof buf)) > 0;) line.append(buf, static_cast<std::size_t>(k));
    ::close(fds[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    remove_child(pid);
    const int rc = WIFEXITED(status) ? WEXITSTATUS(status) : kExitFailure;
    if (rc != kExitOk) return rc;
    std::printf("%s", line.c_str());
    std::fflush(stdout);
    const double r = std::strtod(line.c_str() + line.find(',') + 1, nullptr);
    if (r > peak) {
      peak = r;
      peak_n = n;
    }
  }
  std::printf("peak: %.4g rays/s with %d client(s); results in %s/clients-N/\n", peak, peak_n, opt.out.c_str());
  return kExitOk;
}

}  // namespace rayline::cli

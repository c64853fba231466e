#include "apps/cmd_simulate.hpp"

#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <unistd.h>
#include <vector>

#include "apps/cli_common.hpp"
#include "apps/data_dir.hpp"
#include "apps/platform_path.hpp"
#include "apps/run/child_process.hpp"
#include "apps/run/run_options.hpp"
#include "apps/run/staged_folder.hpp"
#include "common/error.hpp"
#include "common/output_folder.hpp"
#include "sim/peak_search.hpp"
#include "workload/path_trace_graph.hpp"
#include "sim/simulation.hpp"
#include "workload/twin_file.hpp"

namespace rayline::cli {

namespace {
// "boeing" / "museum": the built-in scene profiles among the scene files (apps/data_dir.hpp;
// $RAYLINE_SCENES overrides the folder).
std::string resolve_workload(const std::string& w) {
  if (w != "boeing" && w != "museum") return w;
  return find_data_file("scenes", "RAYLINE_SCENES", w + ".profile.json", "--workload", w);
}

// A resolved --workload: a scene profile (path tracing), the ray stream, or a job-set file.
sim::WorkloadKind workload_kind(const std::string& resolved) {
  if (resolved.ends_with(".profile.json")) return sim::WorkloadKind::PathTrace;
  return resolved == "ray-stream" ? sim::WorkloadKind::RayStream : sim::WorkloadKind::JobSet;
}

// One client count of --clients: an integer in [1, kMaxPtClients], else 0.
int parse_client_count(const std::string& item) {
  char* end = nullptr;
  const long v = std::strtol(item.c_str(), &end, 10);
  return item.empty() || *end != '\0' || v < 1 || v > kMaxPtClients ? 0 : static_cast<int>(v);
}

// --clients auto:M: the automatic sweep measures at most M clients (default: the
// workload's limit).
int auto_max_clients(const std::string& text) {
  if (!text.starts_with("auto:")) return kMaxPtClients;
  const int v = parse_client_count(text.substr(5));
  if (v == 0)
    throw InputError("--clients", "", "expected auto:M with M an integer in [1, " + std::to_string(kMaxPtClients) + "], got '" +
                                          text + "'");
  return v;
}

// --clients: N, a list N1,N2,..., "auto" or "auto:M" (empty: the sweep finds the peak itself).
std::vector<int> client_counts(const std::string& text) {
  std::vector<int> out;
  if (text == "auto") return out;
  if (text.starts_with("auto:")) {
    (void)auto_max_clients(text);  // checked
    return out;
  }
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = text.find(',', pos);
    const int v = parse_client_count(text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos));
    if (v == 0)
      throw InputError("--clients", "", "expected N, a list N1,N2,... of integers in [1, " + std::to_string(kMaxPtClients) +
                                            "], or auto, got '" + text + "'");
    out.push_back(v);
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return out;
}

void print_summary(const sim::SimulationSummary& s, const std::string& out, bool timeline) {
  std::printf("simulated %s in %s wall (%.0fx), %s, %llu activities, scheduler %s (%.2f%% of simulated time)\n",
              format_duration(s.simulated).c_str(), format_duration(s.wall_seconds).c_str(),
              s.wall_seconds > 0 ? s.simulated / s.wall_seconds : 0.0, format_rate(s.rays_per_second, "rays").c_str(),
              static_cast<unsigned long long>(s.activities), format_duration(s.scheduler_seconds).c_str(),
              s.simulated > 0 ? 100 * s.scheduler_seconds / s.simulated : 0.0);
  if (s.path_trace) {
    std::printf("steady state: %s (%s); frames delivered %llu; devices busy %.1f%%, setup %.1f%%, fetching %.1f%%, true idle %.1f%%\n",
                format_rate(s.steady_rays_shot_per_second, "rays shot").c_str(),
                format_rate(s.steady_rays_per_second, "block visits").c_str(), static_cast<unsigned long long>(s.frames_delivered),
                100 * s.busy, 100 * s.setup, 100 * s.fetching, 100 * s.idle);
    // The clients' framebuffers stay on one host memory for the whole run: a memory they
    // fill has little room left for blocks and rays (and none once they overflow it).
    if (s.client_memory_capacity > 0 && s.client_framebuffer_bytes >= 0.5 * s.client_memory_capacity)
      std::printf("note: the clients' framebuffers (%s) take %.0f%% of %s (%s), the host memory where the clients keep "
                  "them (the platform's \"clients\", else its first): %s left there for scene blocks and rays\n",
                  format_size(s.client_framebuffer_bytes).c_str(), 100 * s.client_framebuffer_bytes / s.client_memory_capacity,
                  s.client_memory.c_str(), format_size(s.client_memory_capacity).c_str(),
                  s.client_framebuffer_bytes >= s.client_memory_capacity
                      ? "no room is"
                      : (format_size(s.client_memory_capacity - s.client_framebuffer_bytes) + " is").c_str());
    if (!s.nothing_delivered.empty()) std::printf("note: %s\n", s.nothing_delivered.c_str());
    if (!s.steady)
      std::printf("note: not a steady state: the rays alive grew by %.0f%% of the rays shot after the warm-up (more "
                  "offered load than the cluster absorbs, or a run too short to fill it); read the rate with care\n",
                  100 * s.alive_growth_share);
    else if (s.draining)
      std::printf("note: the rays alive shrank by %.0f%% of the rays shot after the warm-up: part of the rate is rays "
                  "made before it (frames longer than the run); a run over whole frames measures what the cluster "
                  "sustains\n",
                  -100 * s.alive_growth_share);
    if (s.prediction_accuracy >= 0)
      std::printf("prediction accuracy %.1f%% (jobs), %.1f%% (rays)\n", 100 * s.prediction_accuracy,
                  100 * s.prediction_ray_accuracy);
  }
  if (s.twin) {
    const auto rel = [](double sim, double real) { return real > 0 ? 100 * (sim - real) / real : 0.0; };
    std::printf("twin of the recorded render: frame %s (recorded %s, %+.0f%%), %llu loads (recorded %llu, %+.0f%%), "
                "%llu jobs (recorded %llu)\n",
                format_duration(s.simulated).c_str(), format_duration(s.recorded_seconds).c_str(),
                rel(s.simulated, s.recorded_seconds), static_cast<unsigned long long>(s.twin_loads),
                static_cast<unsigned long long>(s.recorded_loads), rel(double(s.twin_loads), double(s.recorded_loads)),
                static_cast<unsigned long long>(s.twin_jobs), static_cast<unsigned long long>(s.recorded_jobs));
  }
  if (s.faults_applied > 0)
    std::printf("faults: %d applied (metrics.json \"faults\": throughput before and after each); rays lost %llu%s\n",
                s.faults_applied, static_cast<unsigned long long>(s.rays_lost),
                s.path_trace ? (", frames asked for again " + std::to_string(s.frames_abandoned)).c_str() : "");
  std::printf("results: %s/metrics.json, jobs.csv%s\n", out.c_str(), timeline ? ", timeline.json" : "");
}
}  // namespace

namespace {
// The path-tracing flags (Sec. 5-6) mean nothing to a ray stream or a job set: a run that
// silently ignored one would not be the run the user asked for.
void check_no_path_trace_flags(const SimulateOptions& opt) {
  const std::vector<int> counts = client_counts(opt.clients);
  std::string given;
  int n = 0;
  const auto flag = [&given, &n](bool set, const char* name) {
    if (set) given += (n++ ? ", " : "") + std::string(name);
  };
  flag(counts.size() != 1 || counts[0] != 1, "--clients");
  flag(opt.prediction_depth != 0, "--prediction-depth");
  flag(opt.frames_in_flight != 1, "--frames-in-flight");
  flag(opt.frames != 0, "--frames");
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

// The path-tracing options, parsed and checked (a workload that is a scene profile).
void path_trace_config(const SimulateOptions& opt, sim::SimulationConfig& cfg) {
  cfg.prediction_depth = opt.prediction_depth;
  cfg.frames_in_flight = opt.frames_in_flight;
  cfg.frames_per_client = opt.frames;
  cfg.merge_planned = opt.merge_planned == "on";
  cfg.cancel_failed = opt.cancel_failed == "on";
  cfg.retime_merged = opt.retime_merged == "on";
  if (!parse_fidelity(opt.fidelity, cfg.fidelity))
    throw InputError("--fidelity", "", "unknown fidelity '" + opt.fidelity + "' (known: analytic, markov, replay)");
  cfg.replay_file = opt.replay;
  if (cfg.fidelity == Fidelity::Replay && cfg.replay_file.empty())
    throw InputError("--replay", "", "--fidelity replay needs --replay FILE (a replay log)");
  cfg.record_replay = opt.record_replay;
  if (cfg.warmup >= cfg.duration) throw InputError("--warmup", "", "must be shorter than --duration");
}

// The run's engine options, checked (the scheduler, the duration, the noise and the
// runtime's order of T-jobs on shared media).
void engine_config(const SimulateOptions& opt, Time horizon, const AgingSetting& aging, sim::SimulationConfig& cfg) {
  cfg.scheduler = scheduler_choice(opt.scheduler, horizon, aging);
  cfg.scheduler.rayline_off = rayline_rules_flag(opt.rayline_off, cfg.scheduler.kind);
  cfg.scheduler.rayline_on = rayline_rules_flag(opt.rayline_on, cfg.scheduler.kind, "--rayline-on");
  if (opt.plan_cell < 0) throw InputError("--plan-cell", "", "must be >= 0 (0: one cell)");
  cfg.scheduler.plan_cell = opt.plan_cell;
  // Shorter than a microsecond nothing can happen (the shortest latency modelled is ~1 us),
  // and per-second rates and shares of such a run run to hundreds of digits.
  if (!(cfg.duration >= 1e-6)) throw InputError("--duration", "", "must be at least 1us");
  if (!(opt.exec_noise >= 0 && opt.exec_noise < 1)) throw InputError("--exec-noise", "", "must be in [0, 1)");
  cfg.exec_noise = opt.exec_noise;
  const std::optional<sim::TransferOrder> order = sim::parse_transfer_order(opt.transfer_order);
  if (!order)
    throw InputError("--transfer-order", "", "unknown order '" + opt.transfer_order + "' (known: channel, resource, exclusive)");
  cfg.transfer_order = *order;
}

// The flags as a SimulationConfig (clients left at 1): every text flag parsed and checked,
// InputError naming the flag otherwise.
// --like NAME.twin.json: the recorded render's platform and scheduler unless --platform /
// --scheduler say otherwise (docs/validation.md).
void twin_config(const SimulateOptions& opt, SimulateOptions& eff, sim::SimulationConfig& cfg) {
  if (opt.workload != SimulateOptions{}.workload)
    throw InputError("--like", "", "replays a recorded render; give --like or --workload, not both");
  if (opt.duration != SimulateOptions{}.duration)
    throw InputError("--duration", "", "a recorded render's twin runs until its frame is done; leave --duration out");
  cfg.workload = opt.like;
  cfg.workload_kind = sim::WorkloadKind::Twin;
  cfg.platform_file = opt.platform.empty() ? std::string() : resolve_platform(opt.platform);
  const TwinSpec twin = load_twin(opt.like);
  cfg.twin_fitted_timing = opt.timing == "recorded";
  if (cfg.twin_fitted_timing && !opt.platform.empty())
    throw InputError("--timing", "", "recorded takes the twin's fitted platform; give --timing recorded or --platform, not both");
  if (!opt.scheduler_given) eff.scheduler = twin.scheduler;
  // A twin replays its log unless told otherwise; the path-tracing flags mean nothing to it.
  if (!opt.fidelity_given) eff.fidelity = "replay";
  if (!parse_fidelity(eff.fidelity, cfg.fidelity) || cfg.fidelity == Fidelity::Analytic)
    throw InputError("--fidelity", "", "a recorded render's twin runs at replay (its ray log) or markov (its statistics), not '" +
                                           eff.fidelity + "'");
  SimulateOptions rest = eff;
  rest.fidelity = SimulateOptions{}.fidelity;
  rest.workload = opt.like;
  check_no_path_trace_flags(rest);
}

sim::SimulationConfig simulate_config(const SimulateOptions& given) {
  sim::SimulationConfig cfg;
  SimulateOptions opt = given;
  if (!given.like.empty()) {
    twin_config(given, opt, cfg);
  } else {
    cfg.platform_file = resolve_platform(opt.platform);
    cfg.workload = resolve_workload(opt.workload);
    cfg.workload_kind = workload_kind(cfg.workload);
    if (opt.timing != SimulateOptions{}.timing) throw InputError("--timing", "", "applies only to a recorded render (--like)");
    if (cfg.workload.ends_with(".twin.json"))
      throw InputError("--workload", cfg.workload, "is a recorded render: run its twin with --like " + cfg.workload);
  }
  const Time horizon = duration_flag("--horizon", opt.horizon);
  const AgingSetting aging = parse_aging(opt.aging, "--aging");
  cfg.duration = duration_flag("--duration", opt.duration);
  cfg.seed = opt.seed;
  cfg.blocks = opt.blocks;
  cfg.out_dir = opt.out;
  cfg.paje = opt.paje;
  cfg.timeline = !opt.no_timeline;
  cfg.progress = ProgressLine::for_stderr(opt.no_progress);
  if (!opt.warmup.empty()) cfg.warmup = duration_flag("--warmup", opt.warmup);
  cfg.faults = opt.fail;  // (checked against the platform when it is loaded)
  if (!opt.memory_budget.empty()) {
    cfg.host_memory = size_flag("--memory-budget", opt.memory_budget);
    if (cfg.host_memory == 0) throw InputError("--memory-budget", "", "must be more than 0 bytes");
  }
  cfg.warm = opt.start == "warm";
  if (cfg.warm && (cfg.workload_kind == sim::WorkloadKind::JobSet || cfg.workload_kind == sim::WorkloadKind::Twin))
    throw InputError("--start", "", "warm applies to the ray stream and to path tracing; a job set and a recorded render "
                                    "say where their data starts");
  if (cfg.workload_kind != sim::WorkloadKind::PathTrace && cfg.workload_kind != sim::WorkloadKind::Twin)
    check_no_path_trace_flags(opt);
  // --blocks sizes the synthetic ray stream's scene; a job set and a scene profile bring their own.
  if (cfg.workload_kind != sim::WorkloadKind::RayStream && opt.blocks != SimulateOptions{}.blocks)
    throw InputError("--blocks", "", "applies only to the ray stream (--workload ray-stream): '" + opt.workload +
                                         "' brings its own blocks");
  engine_config(opt, horizon, aging, cfg);
  if (cfg.workload_kind == sim::WorkloadKind::PathTrace) path_trace_config(opt, cfg);
  return cfg;
}
}  // namespace

void check_simulate_flags(const SimulateOptions& opt) { simulate_config(opt); }

namespace {
std::vector<NamedPath> run_inputs(const SimulateOptions& opt) {
  if (!opt.like.empty()) {
    const std::string rays = load_twin(opt.like).rays_path(opt.like);
    return {{"--platform", opt.platform.empty() ? std::string() : resolve_platform(opt.platform)},
            {"--like", opt.like},
            {"--like (its ray log)", rays}};
  }
  const std::string workload = resolve_workload(opt.workload);
  return {{"--platform", resolve_platform(opt.platform)},
          {"--workload", workload == "ray-stream" ? "" : workload},
          {"--replay", opt.replay}};
}
}  // namespace

void check_run_folder(const SimulateOptions& opt, const std::string& dir) {
  sim::check_results_folder(dir, "--out");
  check_not_inside(dir, "--out", run_inputs(opt));
}

std::string check_results_set(const SimulateOptions& opt, const std::string& dir, const std::vector<std::string>& own,
                              const std::vector<std::string>& own_folders) {
  const OwnFiles files(own.begin(), own.end()), folders(own_folders.begin(), own_folders.end());
  const std::string target = replaceable_folder(dir, "--out", files, folders,
                                                [](const std::string& sub) { sim::check_results_folder(sub, "--out"); });
  check_not_inside(dir, "--out", run_inputs(opt));
  return target;
}

bool run_completed(const std::string& dir) {
  std::error_code ec;
  return std::filesystem::is_regular_file(std::filesystem::path(dir) / "metrics.json", ec);
}

namespace {
// One point of a client sweep, in a child process: its CSV line into `fd`; the exit code.
int sweep_point(const sim::SimulationConfig& cfg, int clients, const std::string& out, int fd) {
  try {
    sim::SimulationConfig c = cfg;
    c.clients = clients;
    c.out_dir = out + "/clients-" + std::to_string(clients);
    c.progress = ProgressLine::Mode::Off;
    const sim::SimulationSummary s = sim::run_simulation(c);
    char line[512];
    const int len = std::snprintf(line, sizeof line, "%d,%.6g,%.6g,%.4f,%.4f,%.4f,%.4f,%.4f,%llu,%d,%.4f\n", clients,
                                  s.steady_rays_shot_per_second, s.steady_rays_per_second, s.prediction_accuracy, s.busy,
                                  s.setup, s.fetching, s.idle, static_cast<unsigned long long>(s.frames_delivered),
                                  s.steady ? 1 : 0, s.alive_growth_share);
    if (::write(fd, line, static_cast<std::size_t>(len)) != len) return kExitFailure;
    if (s.stalled) std::fprintf(stderr, "rayline: %d client(s): %s\n", clients, s.stalled_reason.c_str());
    return s.stalled ? kExitFailure : kExitOk;
  } catch (const InputError& e) {
    std::fprintf(stderr, "rayline: %s\n", e.what());
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rayline: %s\n", e.what());
    return kExitFailure;
  }
}

// A sweep (Sec. 6: "we increase the number of clients until each method reaches its peak
// performance"): one process per point, results in OUT/clients-N/; the summary line of
// each and the peak. The points write into a staging folder, published as OUT once every
// point completed (a stalled point completes: its results say so, and the sweep exits 1).
// With no counts (--clients auto) the sweep finds the peak itself (sim/peak_search.hpp):
// doubling client counts until two in a row gain no more than 2 %.
// The points of a sweep written straight into `dir` (clients-N/ each). `complete`: every
// point wrote its results (a stalled point does, and makes the exit code 1).
struct SweepResult {
  int rc = kExitOk;
  bool complete = false;
  int peak_n = 0;
  double peak = 0;
};

SweepResult sweep_into(const SimulateOptions& opt, const sim::SimulationConfig& cfg, const std::vector<int>& counts,
                       const std::string& dir) {
  SweepResult res;
  double& peak = res.peak;
  int& peak_n = res.peak_n;
  bool stalled = false;
  std::printf("clients,steady_rays_shot_per_second,steady_block_visits_per_second,prediction_accuracy,busy,setup,fetching,idle,"
              "frames,steady,alive_growth_share\n");
  std::fflush(stdout);
  std::vector<sim::PeakPoint> points;
  std::size_t k = 0;
  sim::PeakSearch search;
  search.max_clients = auto_max_clients(opt.clients);
  const auto next = [&] { return counts.empty() ? sim::next_peak_point(points, search) : k < counts.size() ? counts[k++] : 0; };
  for (int n = next(); n != 0; n = next()) {
    std::string line;  // one process per point
    const int rc = run_in_child([&](int fd) { return sweep_point(cfg, n, dir, fd); }, line);
    if (rc != kExitOk && (rc != kExitFailure || !run_completed(dir + "/clients-" + std::to_string(n)))) {
      if (rc != kExitBadInput)
        std::fprintf(stderr, "rayline: the run with %d client(s) failed; nothing is published under %s\n", n,
                     opt.out.c_str());
      res.rc = rc;
      return res;
    }
    stalled = stalled || rc != kExitOk;
    std::printf("%s", line.c_str());
    std::fflush(stdout);
    // The line's 2nd field: rays shot per second; its 10th: steady (1) or not (0).
    std::vector<std::string_view> f;
    for (std::size_t a = 0, b; a <= line.size(); a = b + 1) {
      b = std::min(line.find_first_of(",\n", a), line.size());
      f.emplace_back(line.data() + a, b - a);
    }
    const double r = f.size() > 1 ? std::strtod(std::string(f[1]).c_str(), nullptr) : 0.0;
    const bool grows = f.size() > 9 && f[9] == "0";
    // --steady strict: a point whose rays alive shrank (its 11th field) is no peak either.
    const bool drains = opt.steady == "strict" && f.size() > 10 &&
                        std::strtod(std::string(f[10]).c_str(), nullptr) < -sim::kSteadyGrowth;
    points.push_back({n, r, !grows && !drains});
    if (grows)
      std::printf("note: with %d client(s) the rays alive still grow (path_trace.steady in its metrics.json): not a "
                  "steady state, not a peak\n", n);
    if (drains)
      std::printf("note: with %d client(s) the rays alive shrank (a backlog made before the window traced): not "
                  "steady under --steady strict, not a peak\n", n);
    std::fflush(stdout);  // (the next point's child process would print it again)
  }
  const sim::PeakPoint best = sim::peak_of(points);
  peak = best.rate;
  peak_n = best.clients;
  std::printf("peak: %s with %d client(s)%s; results in %s/clients-N/\n", format_rate(peak, "rays shot").c_str(), peak_n,
              best.steady ? "" : " (no steady point)", opt.out.c_str());
  res.rc = stalled ? kExitFailure : kExitOk;
  res.complete = true;
  return res;
}

int run_sweep(const SimulateOptions& opt, const sim::SimulationConfig& cfg, const std::vector<int>& counts) {
  const auto check = [&] { return check_results_set(opt, opt.out, {"report.html"}, {"clients-*"}); };
  StagedFolder stage(check(), opt.out, "--out", check);
  const SweepResult r = sweep_into(opt, cfg, counts, stage.path());
  if (!r.complete) return r.rc;
  stage.publish();
  return r.rc;
}

// One run with opt.clients clients, its results folder written at `dir`; prints the
// summary naming opt.out, and the reason of a stall.
int run_one(const SimulateOptions& opt, sim::SimulationConfig cfg, const std::string& dir) {
  cfg.clients = client_counts(opt.clients)[0];
  cfg.out_dir = dir;
  const sim::SimulationSummary s = sim::run_simulation(cfg);
  print_summary(s, opt.out, cfg.timeline);
  if (s.stalled) {
    std::fprintf(stderr, "rayline: %s\n", s.stalled_reason.c_str());
    return kExitFailure;
  }
  return kExitOk;
}
}  // namespace

int run_simulate(const SimulateOptions& opt) {
  sim::SimulationConfig cfg = simulate_config(opt);
  const std::vector<int> counts = client_counts(opt.clients);
  // Before any run: a folder holding the user's files is never replaced, nor one an input lies in.
  for (int n : counts) check_run_folder(opt, counts.size() == 1 ? opt.out : opt.out + "/clients-" + std::to_string(n));
  if (counts.size() != 1) return run_sweep(opt, cfg, counts);
  return run_one(opt, cfg, opt.out);
}

int run_simulate_into(const SimulateOptions& opt, const std::string& dir) { return run_one(opt, simulate_config(opt), dir); }

int run_sweep_into(const SimulateOptions& opt, const std::string& dir, int& peak_clients) {
  const SweepResult r = sweep_into(opt, simulate_config(opt), client_counts(opt.clients), dir);
  peak_clients = r.peak_n;
  return r.complete || r.rc == kExitBadInput ? r.rc : kExitFailure;
}

}  // namespace rayline::cli

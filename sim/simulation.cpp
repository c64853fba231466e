#include "sim/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "common/error.hpp"
#include "workload/job_set.hpp"
#include "common/output_folder.hpp"
#include "common/unfinished_output.hpp"
#include "workload/path_trace_workload.hpp"
#include "sched/io/platform_loader.hpp"
#include "workload/ray_stream.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "sched/policy/scheduler_factory.hpp"
#include "sched/io/trace_output.hpp"
#include "sched/policy/unplaced.hpp"
#include "sched/timeline/utilisation.hpp"
#include "sim/sim_executor.hpp"

namespace rayline::sim {

namespace {

// What a run writes into its folder (the only files replacing it may remove).
const OwnFiles kRunFiles = {"metrics.json", "jobs.csv", "timeline.json", "simgrid.trace", "replay.log"};
TransferOrder parse_transfer_order(const std::string& s) {
  if (s == "channel") return TransferOrder::Channel;
  if (s == "resource") return TransferOrder::Resource;
  if (s == "exclusive") return TransferOrder::Exclusive;
  throw InputError("--transfer-order", "", "unknown order '" + s + "' (known: channel, resource, exclusive)");
}

// (Into the run's partial folder, renamed only once every file is complete.)
template <class Write>
void write_file(const std::filesystem::path& p, const Write& write) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  write(out);
  out.flush();
  if (!out) throw std::runtime_error("cannot write " + p.string());
}

void write_text(const std::filesystem::path& p, const std::string& text) {
  write_file(p, [&](std::ostream& out) { out << text; });
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(static_cast<double>(v.size() - 1), q * static_cast<double>(v.size())))];
}

double mean_of(const std::vector<double>& v) {
  double t = 0;
  for (double x : v) t += x;
  return v.empty() ? 0.0 : t / static_cast<double>(v.size());
}

std::uint64_t work_of(const PathTraceWorkload& pt) {
  std::uint64_t w = 0;
  for (const auto& [t, n] : pt.traced()) w += n;
  return w;
}

// metrics.json "path_trace": rays created/ended, frames, steady-state throughput (after
// the warm-up), prediction accuracy (Sec. 5.2; definitions in docs/scene-profiles.md).
void path_trace_metrics(nlohmann::json& m, const PathTraceWorkload& pt, const SceneProfile& prof,
                        const SimulationConfig& cfg, Time end, SimulationSummary& sum) {
  const Time warm = cfg.warmup >= 0 ? cfg.warmup : end / 3;
  double traced = 0, ended = 0;
  for (const auto& [t, n] : pt.traced())
    if (t >= warm) traced += static_cast<double>(n);
  for (const auto& [t, n] : pt.ended_series())
    if (t >= warm) ended += static_cast<double>(n);
  const double span = std::max(1e-9, end - warm);
  const RayTally& r = pt.tally();
  std::uint64_t exact = 0;
  double latency = 0;
  for (const FrameReport& f : pt.frames()) {
    exact += f.exact ? 1 : 0;
    latency += f.delivered - f.requested;
  }
  nlohmann::json j;
  j["scene"] = prof.name;
  j["profile"] = cfg.workload;
  j["fidelity"] = to_string(pt.model().fidelity());
  j["clients"] = cfg.clients;
  j["prediction_depth"] = cfg.prediction_depth;
  j["merge_planned"] = cfg.merge_planned;
  j["retime_merged"] = cfg.retime_merged;
  j["image"] = {{"width", prof.width}, {"height", prof.height}, {"spp", prof.spp}};
  j["warmup_s"] = warm;
  j["steady_rays_per_second"] = traced / span;
  j["steady_rays_ended_per_second"] = ended / span;
  j["rays"] = {{"primary", r.primary}, {"secondary", r.secondary}, {"shadow", r.shadow}, {"created", r.created()},
               {"hit", r.hit}, {"escaped", r.escaped}, {"occluded", r.occluded}, {"lit", r.lit}, {"ended", r.ended()},
               {"alive_at_end", pt.rays_alive()}};
  j["frames"] = {{"delivered", pt.frames().size()}, {"exact", exact},
                 {"mean_latency_s", pt.frames().empty() ? 0.0 : latency / static_cast<double>(pt.frames().size())}};
  nlohmann::json jobs;
  for (int k = 0; k < kPtJobCount; ++k)
    jobs[std::string(kPtJobTypeNames[static_cast<std::size_t>(k)])] = pt.jobs_of(static_cast<PtJob>(k));
  j["jobs"] = jobs;
  j["queue_merges"] = pt.merges();
  j["queue_merges_into_planned"] = pt.merges_into_planned();
  if (const PredictionStats* p = pt.prediction()) {
    j["prediction"] = {{"created", p->created}, {"confirmed", p->confirmed}, {"confirmed_planned", p->confirmed_planned},
                       {"failed", p->failed}, {"superseded", p->superseded}, {"accuracy", p->accuracy()},
                       {"ray_accuracy", p->ray_accuracy()}, {"cancel_failed", cfg.cancel_failed},
                       {"withdrawn", {{"e_jobs", pt.withdrawn().execs}, {"t_jobs", pt.withdrawn().transfers},
                                      {"t_jobs_kept", pt.withdrawn().kept_transfers},
                                      {"t_job_bytes", pt.withdrawn().bytes}}}};
    sum.prediction_accuracy = p->accuracy();
    sum.prediction_ray_accuracy = p->ray_accuracy();
  }
  if (pt.model().fidelity() == Fidelity::Replay)
    j["replay"] = {{"replayed_rays", pt.model().replayed_rays()}, {"fallback_rays", pt.model().fallback_rays()},
                   {"exact_pieces", pt.model().exact_pieces()}};
  m["path_trace"] = j;
  sum.path_trace = true;
  sum.steady_rays_per_second = traced / span;
  sum.frames_delivered = pt.frames().size();
}

}  // namespace

void check_results_folder(const std::string& dir, const std::string& flag) { replaceable_folder(dir, flag, kRunFiles); }

SimulationSummary run_simulation(const SimulationConfig& cfg) {
  namespace fs = std::filesystem;
  using nlohmann::json;
  const auto wall0 = std::chrono::steady_clock::now();
  if (cfg.scheduler != "gmb" && cfg.scheduler != "gmb-ca" && cfg.scheduler != "loadanyonce" && cfg.scheduler != "budge")
    throw InputError("--scheduler", "", "unknown scheduler '" + cfg.scheduler + "' (known: gmb, gmb-ca, loadanyonce, budge)");
  if (!(cfg.horizon > 0)) throw InputError("--horizon", "", "must be > 0");
  if (std::isnan(cfg.aging)) throw InputError("--aging", "", "must be a duration, auto, adaptive or off");
  // Shorter than a microsecond nothing can happen (the shortest latency modelled is ~1 us),
  // and per-second rates and shares of such a run run to hundreds of digits.
  if (!(cfg.duration >= 1e-6)) throw InputError("--duration", "", "must be at least 1us");
  if (!(cfg.exec_noise >= 0 && cfg.exec_noise < 1)) throw InputError("--exec-noise", "", "must be in [0, 1)");
  const TransferOrder transfer_order = parse_transfer_order(cfg.transfer_order);
  const DeviceGraph g = load_platform(cfg.platform_file);
  const bool path_trace = cfg.workload.ends_with(".profile.json");
  const bool stream = cfg.workload == "ray-stream" || path_trace;  // runs for --duration
  std::unique_ptr<JobSet> set;
  if (!stream) set = std::make_unique<JobSet>(load_job_set(cfg.workload, g));  // validate before any output
  // Path tracing: the scene profile, fidelity and replay log, all validated before any output.
  std::unique_ptr<SceneProfile> profile;
  PathTraceOptions pto;
  if (path_trace) {
    profile = std::make_unique<SceneProfile>(load_scene_profile(cfg.workload));
    if (!parse_fidelity(cfg.fidelity, pto.fidelity))
      throw InputError("--fidelity", "", "unknown fidelity '" + cfg.fidelity + "' (known: analytic, markov, replay)");
    if (pto.fidelity == Fidelity::Replay) {
      if (cfg.replay_file.empty()) throw InputError("--replay", "", "--fidelity replay needs --replay FILE (a replay log)");
      pto.replay = std::make_shared<ReplayLog>(ReplayLog::load(cfg.replay_file, profile.get()));
    }
    if (cfg.warmup >= cfg.duration) throw InputError("--warmup", "", "must be shorter than --duration");
    pto.clients = cfg.clients;
    pto.prediction_depth = cfg.prediction_depth;
    pto.merge_planned = cfg.merge_planned;
    pto.cancel_failed = cfg.cancel_failed;
    pto.retime_merged = cfg.retime_merged;
    pto.seed = cfg.seed;
  }
  ReplayLog recording;
  if (cfg.record_replay && !path_trace) throw InputError("--record-replay", "", "only for a path-tracing workload");
  if (cfg.record_replay) pto.record = &recording;

  const std::string out = replaceable_folder(cfg.out_dir, "", kRunFiles);
  const fs::path partial = partial_folder(out);
  const unfinished::Guard unfinished_guard(partial.string());  // removed if the run is interrupted
  std::error_code ec;
  fs::remove_all(partial, ec);
  fs::create_directories(partial, ec);
  if (ec) throw InputError(cfg.out_dir, "", "cannot create output directory: " + ec.message());
  struct Cleanup {
    fs::path p;
    bool keep = false;
    ~Cleanup() {
      std::error_code e;
      if (!keep) fs::remove_all(p, e);
    }
  } cleanup{partial};

  SgOptions sgo;
  if (cfg.paje)
    sgo.config = {"tracing:yes", "tracing/uncategorized:yes", "tracing/precision:9",
                  "tracing/filename:" + (partial / "simgrid.trace").string()};
  SgPlatform platform(g, sgo);
  JobPool pool_local;
  JobPool& pool = set ? set->pool : pool_local;
  Schedule s(g, pool);
  std::unique_ptr<Workload> wl;
  RayStreamWorkload* rs = nullptr;
  PathTraceWorkload* pt = nullptr;
  if (path_trace) {
    auto w = std::make_unique<PathTraceWorkload>(g, *profile, pto);
    pt = w.get();
    wl = std::move(w);
  } else if (stream) {
    RayStreamOptions ro;
    ro.blocks = cfg.blocks;
    ro.seed = cfg.seed;
    auto w = std::make_unique<RayStreamWorkload>(g, ro);
    rs = w.get();
    wl = std::move(w);
  } else {
    for (auto [b, m] : set->initial) s.put_initial(b, m);
    wl = std::make_unique<StaticWorkload>();
  }
  std::unique_ptr<Scheduler> scheduler = make_scheduler(cfg.scheduler, cfg.horizon, cfg.aging, cfg.adaptive_aging);
  SimExecutorOptions xo;
  xo.transfer_order = transfer_order;
  if (cfg.exec_noise > 0) {
    const double n = cfg.exec_noise;
    const std::uint64_t seed = cfg.seed;
    xo.exec_factor = [n, seed](ActivityId id, const Activity&) {
      std::uint64_t z = seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(id) * 0xBF58476D1CE4E5B9ull;
      z = (z ^ (z >> 31)) * 0x94D049BB133111EBull;
      z ^= z >> 29;
      return 1 - n + 2 * n * (static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0));
    };
  }
  if (pt) {  // predicted jobs planned before their real rays were known run for their real size
    auto noise = xo.exec_factor;
    xo.exec_factor = [pt, noise](ActivityId id, const Activity& a) {
      return pt->exec_scale(a.job, a.device, a) * (noise ? noise(id, a) : 1.0);
    };
  }
  SimExecutor ex(platform, s, xo);
  RuntimeLoop loop(*scheduler, ex, *wl, pool, s);
  ProgressLine progress(cfg.progress);
  if (progress.mode() != ProgressLine::Mode::Off) {
    loop.on_progress = [&](Time now, const RunStats&) {
      if (!progress.due()) return;
      const double rays = rs ? static_cast<double>(rs->rays_traced()) : pt ? static_cast<double>(work_of(*pt)) : 0.0;
      if (stream)
        progress.print("simulate", "t=%7.2f / %.0f s  rays %.3g  activities %zu", now, cfg.duration, rays,
                       s.activity_count());
      else
        progress.print("simulate", "t=%7.2f s  jobs left %zu  activities %zu", now, pool.queued_count(),
                       s.activity_count());
    };
  }
  const auto run0 = std::chrono::steady_clock::now();
  const RunStats st = loop.run(stream ? cfg.duration : kNever);
  // A stream never drains, so the loop cannot see a stall; a queued job that no device can
  // ever run (too big for every memory device, no path) is one all the same: any queued
  // job, not only the oldest (the rays it holds are lost either way).
  const bool stalled = st.stalled || first_unplaceable(pool, s) != kNone;
  const double run_wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - run0).count();
  progress.done();
  const Time end = stream ? cfg.duration : st.makespan;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();

  // ---- metrics ---------------------------------------------------------------------
  json m;
  m["platform"] = g.name;
  m["platform_file"] = cfg.platform_file;
  m["workload"] = cfg.workload;
  m["scheduler"] = cfg.scheduler;
  m["scheduler_parameters"] = scheduler->describe();
  m["horizon_s"] = cfg.horizon;
  m["transfer_order"] = cfg.transfer_order;
  m["seed"] = cfg.seed;
  m["simulated_s"] = end;
  // Plan vs reality for the whole run: the latest planned end of what finished, and when
  // it actually finished (static job sets: the predicted and the measured makespan).
  Time planned_ms = 0, actual_ms = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.state != ActivityState::Done || a.cancelled) continue;
    planned_ms = std::max(planned_ms, a.planned_end);
    actual_ms = std::max(actual_ms, a.end);
  }
  m["makespan_s"] = {{"planned", planned_ms}, {"actual", actual_ms}, {"gap", actual_ms - planned_ms}};
  m["stalled"] = stalled;
  std::uint64_t done_exec = 0, done_transfer = 0, cancelled_exec = 0, cancelled_transfer = 0;
  std::vector<double> err_exec, err_transfer;
  double work_done = 0;
  std::vector<double> per_second(static_cast<std::size_t>(std::ceil(std::max<Time>(end, 1e-9))), 0.0);
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.cancelled) {  // withdrawn predictions (Sec. 5.2): no work, no error sample
      ++(a.kind == ActivityKind::Exec ? cancelled_exec : cancelled_transfer);
      continue;
    }
    if (a.state != ActivityState::Done) continue;
    const double actual = a.end - a.start;
    const double rel = a.duration > 0 ? std::abs(actual - a.duration) / a.duration : 0;
    if (a.kind == ActivityKind::Exec) {
      ++done_exec;
      err_exec.push_back(rel);
      const double w = static_cast<double>(pool.job(a.job).work);
      work_done += w;
      const auto bin = std::min(per_second.size() - 1, static_cast<std::size_t>(std::max(0.0, a.end)));
      per_second[bin] += w;
    } else {
      ++done_transfer;
      err_transfer.push_back(rel);
    }
  }
  // How long E-jobs waited in the global queue before they ran (start - created; Sec. 4.3's
  // starvation shows as a long tail), and the longest wait of a job still queued at the end.
  std::vector<double> waits;
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.kind == ActivityKind::Exec && !a.cancelled && a.state == ActivityState::Done)
      waits.push_back(std::max(0.0, a.start - pool.job(a.job).created));
  }
  double oldest_queued = 0;
  for (JobId j : pool.queued()) oldest_queued = std::max(oldest_queued, end - pool.job(j).created);
  m["queue_wait_s"] = {{"mean", mean_of(waits)}, {"p50", percentile(waits, 0.5)}, {"p95", percentile(waits, 0.95)},
                       {"max", waits.empty() ? 0.0 : *std::max_element(waits.begin(), waits.end())},
                       {"oldest_queued_at_end", oldest_queued}};
  m["work_units_done"] = work_done;
  m["rays_per_second"] = end > 0 ? work_done / end : 0;
  m["rays_per_second_series"] = per_second;
  m["activities"] = {{"e_jobs_done", done_exec}, {"t_jobs_done", done_transfer},
                     {"committed", s.activity_count()}, {"evictions", s.evictions().size()},
                     {"queued_at_end", pool.queued_count()}, {"e_jobs_cancelled", cancelled_exec},
                     {"t_jobs_cancelled", cancelled_transfer}};
  if (rs) m["activities"]["queue_merges"] = rs->merges();
  SimulationSummary sum;
  if (pt) path_trace_metrics(m, *pt, *profile, cfg, end, sum);
  m["prediction_error"] = {{"exec_mean_rel", mean_of(err_exec)}, {"exec_p95_rel", percentile(err_exec, 0.95)},
                           {"transfer_mean_rel", mean_of(err_transfer)}, {"transfer_p95_rel", percentile(err_transfer, 0.95)}};
  const Utilisation u = compute_utilisation(s, 0, end);
  json devs = json::array();
  std::map<std::string, DeviceTime> by_kind;
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const DeviceTime& t = u.devices[d];
    devs.push_back({{"name", g.computes[d].name}, {"kind", to_string(g.computes[d].kind)}, {"busy_s", t.busy},
                    {"setup_s", t.setup}, {"fetching_s", t.fetching}, {"idle_s", t.idle},
                    {"utilisation", t.utilisation(u.span)}});
    DeviceTime& k = by_kind[std::string(to_string(g.computes[d].kind))];
    k.busy += t.busy;
    k.setup += t.setup;
    k.fetching += t.fetching;
    k.idle += t.idle;
  }
  m["devices"] = devs;
  for (const auto& [k, t] : by_kind) {
    const double tot = std::max(1e-300, t.busy + t.setup + t.fetching + t.idle);
    m["device_summary"][k] = {{"busy", t.busy / tot}, {"setup", t.setup / tot}, {"fetching", t.fetching / tot},
                              {"true_idle", t.idle / tot}};
  }
  // Channel utilisation: bytes moved (exact SimGrid integral) / (bandwidth x time).
  std::vector<char> is_lan(g.resources.size(), 0);
  for (const Channel& c : g.channels)
    if (c.kind == "lan")
      for (ResourceId r : c.resources) is_lan[r] = 1;
  json res = json::array();
  double lan_sum = 0;
  int lan_n = 0;
  for (std::size_t r = 0; r < g.resources.size(); ++r) {
    const double bytes = platform.resource_bytes(static_cast<ResourceId>(r));
    const double util = end > 0 ? bytes / (g.resources[r].bandwidth * end) : 0;
    res.push_back({{"resource", g.resources[r].name}, {"bandwidth_Bps", g.resources[r].bandwidth}, {"bytes", bytes},
                   {"utilisation", util}, {"lan", static_cast<bool>(is_lan[r])}});
    if (is_lan[r]) {
      lan_sum += util;
      ++lan_n;
    }
  }
  m["resources"] = res;
  m["lan_utilisation_mean"] = lan_n ? lan_sum / lan_n : 0.0;
  m["scheduler_cost"] = {{"wall_s", st.scheduler_wall_seconds}, {"plan_calls", st.plan_calls},
                         {"share_of_simulated_time", end > 0 ? st.scheduler_wall_seconds / end : 0}};
  // Where the time goes: SimGrid (solver + event queue) = the run minus our callbacks;
  // the scheduler (GMB plan calls); bookkeeping (runtime loop, executor, workload).
  const double in_callbacks = ex.callback_wall_seconds();
  m["simulator"] = {{"wall_s", wall},
                    {"run_wall_s", run_wall},
                    {"simgrid_s", std::max(0.0, run_wall - in_callbacks)},
                    {"scheduler_s", st.scheduler_wall_seconds},
                    {"bookkeeping_s", std::max(0.0, in_callbacks - st.scheduler_wall_seconds)},
                    {"setup_and_metrics_s", std::max(0.0, wall - run_wall)},
                    {"speedup_vs_simulated", wall > 0 ? end / wall : 0},
                    {"activities_per_wall_s", wall > 0 ? static_cast<double>(done_exec + done_transfer) / wall : 0}};

  write_text(partial / "metrics.json", m.dump(2) + "\n");
  write_file(partial / "jobs.csv", [&](std::ostream& out) { write_jobs_csv(s, out); });
  if (cfg.timeline) write_file(partial / "timeline.json", [&](std::ostream& out) { write_chrome_trace(s, true, out); });
  if (cfg.record_replay)
    recording.save((partial / "replay.log").string(), "scene=" + profile->name + " fidelity=" + cfg.fidelity + " seed=" +
                                                          std::to_string(cfg.seed) + " clients=" + std::to_string(cfg.clients));
  // Checked again: the user may have put a file there while the run went on.
  replaceable_folder(cfg.out_dir, "", kRunFiles);
  publish_folder(partial.string(), out, "");
  cleanup.keep = true;

  sum.simulated = end;
  sum.wall_seconds = wall;
  sum.scheduler_seconds = st.scheduler_wall_seconds;
  sum.rays_per_second = end > 0 ? work_done / end : 0;
  sum.activities = done_exec + done_transfer;
  sum.stalled = stalled;
  sum.queued_at_end = pool.queued_count();
  if (stalled) sum.stalled_reason = unplaced_summary(pool, s);
  double tot = 0;
  for (const auto& [k, t] : by_kind) tot += t.busy + t.setup + t.fetching + t.idle;
  for (const auto& [k, t] : by_kind) {
    sum.busy += t.busy / std::max(tot, 1e-300);
    sum.setup += t.setup / std::max(tot, 1e-300);
    sum.fetching += t.fetching / std::max(tot, 1e-300);
    sum.idle += t.idle / std::max(tot, 1e-300);
  }
  return sum;
}

}  // namespace rayline::sim

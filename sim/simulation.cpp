#include "sim/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sys/resource.h>

#include "common/error.hpp"
#include "workload/job_set.hpp"
#include "common/output_folder.hpp"
#include "common/unfinished_output.hpp"
#include "workload/compute_bound.hpp"
#include "workload/path_trace_workload.hpp"
#include "workload/ray_flow_expectation.hpp"
#include "sched/io/platform_loader.hpp"
#include "workload/ray_stream.hpp"
#include "workload/render_twin.hpp"
#include "workload/twin_file.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "sched/runtime/fault.hpp"
#include "common/invocation.hpp"
#include "sched/policy/scheduler_factory.hpp"
#include "sched/io/trace_output.hpp"
#include "sched/policy/unplaced.hpp"
#include "sched/timeline/utilisation.hpp"
#include "sim/sim_executor.hpp"

namespace rayline::sim {

namespace {

using nlohmann::json;

// What a run writes into its folder (the only files replacing it may remove), and the
// page `rayline report` writes there by default (it describes the run being replaced).
const OwnFiles kRunFiles = {"metrics.json", "jobs.csv", "timeline.json", "simgrid.trace", "replay.log", "report.html"};

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
  for (const RaySpan& r : pt.traced()) w += r.rays;
  return w;
}

// metrics.json "path_trace": rays created/ended, frames, steady-state throughput (after
// the warm-up), prediction accuracy (Sec. 5.2; definitions in docs/scene-profiles.md).
void path_trace_metrics(nlohmann::json& m, const PathTraceWorkload& pt, const SceneProfile& prof,
                        const SimulationConfig& cfg, Time end, SimulationSummary& sum) {
  const Time warm = cfg.warmup >= 0 ? cfg.warmup : end / 3;
  double traced = 0, ended = 0;
  // The work done inside the window: each job's rays pro rata to the part of its run
  // inside [warm, end] (counting a job's rays at its end would credit the window with work
  // done before it: seconds-long jobs make that several per cent of a short window).
  for (const RaySpan& r : pt.traced()) traced += r.within(warm, end + 1e-9);
  for (const RaySpan& r : pt.ended_series()) ended += r.within(warm, end + 1e-9);
  double created = 0;
  for (const RaySpan& r : pt.created_series()) created += r.within(warm, end + 1e-9);
  const double span = std::max(1e-9, end - warm);
  // Steady state (the paper measures "peak performance", a rate that holds): the rays
  // alive may not grow by more than kSteadyGrowth of the rays shot inside the window. An
  // offered load above the cluster's throughput fills the clients' in-flight budgets and
  // looks fast meanwhile (camera rays that miss end at once, the expensive rest queues).
  // A population that fills (nearly: kBudgetFull) the clients' in-flight budgets cannot
  // grow further: the clients throttle themselves, and what remains of the filling is the
  // last few per cent of a budget that a short window did not see completed.
  constexpr double kBudgetFull = 0.9;
  const double growth = created - ended;
  const double growth_share = ended > 0 ? growth / ended : (growth > 0 ? 1.0 : 0.0);
  const double budget = static_cast<double>(cfg.clients) * std::max(1, cfg.frames_in_flight) *
                        static_cast<double>(prof.inflight_rays);
  const double budget_share = budget > 0 ? static_cast<double>(pt.rays_alive()) / budget : 0.0;
  const bool steady = growth_share <= kSteadyGrowth || budget_share >= kBudgetFull;
  // The other way: rays alive that shrink by more than that (frames longer than the run,
  // whose rays were made before the window) mean part of the rate is a backlog traced. It
  // counts as steady (no overload), and is reported so that a reader knows the rate is
  // the frames' first seconds, not what the cluster sustains frame after frame.
  const bool draining = growth_share < -kSteadyGrowth;
  // Rays shot per simulated second [k, k + 1), each job's rays pro rata to its run.
  std::vector<double> shot_series(static_cast<std::size_t>(std::max(0.0, std::ceil(end - 1e-9))), 0.0);
  for (const RaySpan& r : pt.ended_series()) {
    const auto first = static_cast<std::size_t>(std::max(0.0, std::floor(r.start)));
    for (std::size_t k = first; k < shot_series.size() && static_cast<double>(k) <= r.end; ++k)
      shot_series[k] += r.within(static_cast<double>(k), static_cast<double>(k + 1));
  }
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
  j["frames_in_flight"] = cfg.frames_in_flight;
  j["frames_per_client"] = cfg.frames_per_client;
  j["prediction_depth"] = cfg.prediction_depth;
  j["merge_planned"] = cfg.merge_planned;
  j["retime_merged"] = cfg.retime_merged;
  j["image"] = {{"width", prof.width}, {"height", prof.height}, {"spp", prof.spp}};
  j["warmup_s"] = warm;
  // The paper's unit (Sec. 6): rays shot per second, camera + secondary + shadow rays each
  // counted once, when it ends. Block visits (a ray intersected in one block; a ray that
  // crosses cells visits several) beside it, named as such; steady_rays_per_second is
  // their former name.
  j["steady_rays_shot_per_second"] = ended / span;
  j["steady_block_visits_per_second"] = traced / span;
  j["steady_rays_per_second"] = traced / span;
  j["steady_rays_ended_per_second"] = ended / span;
  j["rays_shot_per_second_series"] = shot_series;
  j["steady"] = {{"steady", steady},
                 {"draining", draining},
                 {"alive_growth", growth},
                 {"alive_growth_share_of_shot", growth_share},
                 {"limit", kSteadyGrowth},
                 {"alive_share_of_inflight_budget", budget_share},
                 {"budget_full", kBudgetFull}};
  j["rays"] = {{"primary", r.primary}, {"secondary", r.secondary}, {"shadow", r.shadow}, {"created", r.created()},
               {"hit", r.hit}, {"escaped", r.escaped}, {"occluded", r.occluded}, {"lit", r.lit}, {"ended", r.ended()},
               {"lost", r.lost}, {"alive_at_end", pt.rays_alive()}};
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
  sum.steady_rays_shot_per_second = ended / span;
  sum.steady = steady;
  sum.alive_growth_share = growth_share;
  sum.draining = draining;
  sum.frames_delivered = pt.frames().size();
}

// metrics.json "path_trace.bound": the compute bound of this platform and profile
// (workload/compute_bound.hpp) and the expected ray flow behind it, so a run's throughput
// can be read against the most any schedule could reach.
void bound_metrics(nlohmann::json& pt, const DeviceGraph& g, const SceneProfile& prof, Fidelity fidelity,
                   SimulationSummary& sum) {
  const RayFlowExpectation flow = expected_ray_flow(prof, fidelity);
  const ComputeBound b = compute_bound(g, prof, flow);
  nlohmann::json kinds = nlohmann::json::array();
  for (const ComputeBound::Kind& k : b.kinds)
    kinds.push_back({{"kind", k.kind}, {"devices", k.devices}, {"busy_share", k.busy_share},
                     {"block_visits_per_second", k.block_visits_per_second}});
  auto finite = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  pt["bound"] = {{"compute_rays_shot_per_second", finite(b.rays_shot_per_second)},
                 {"compute_block_visits_per_second", finite(b.block_visits_per_second)},
                 {"compute_camera_rays_per_second", finite(b.camera_rays_per_second)},
                 {"by_kind", kinds},
                 {"limit", b.limit},
                 {"per_camera_ray", {{"rays_shot", flow.rays_shot()}, {"block_visits", flow.block_visits()},
                                     {"secondary", flow.secondary}, {"shadow", flow.shadow_rays}}}};
  const double steady = pt.value("steady_rays_shot_per_second", 0.0);
  pt["bound"]["share_of_compute_bound"] =
      std::isfinite(b.rays_shot_per_second) && b.rays_shot_per_second > 0 ? steady / b.rays_shot_per_second : 0.0;
  sum.compute_bound_rays_shot_per_second = b.rays_shot_per_second;
}

// ---- setup ---------------------------------------------------------------------------

// What the run reads, loaded before any output: a bad file is reported with the folder
// untouched.
struct Inputs {
  DeviceGraph graph;
  std::unique_ptr<JobSet> set;            // WorkloadKind::JobSet
  std::unique_ptr<SceneProfile> profile;  // WorkloadKind::PathTrace
  TwinSpec twin;                          // WorkloadKind::Twin, and its ray log
  std::shared_ptr<const RayLog> twin_rays;
  Fidelity twin_fidelity = Fidelity::Replay;
  Bytes host_memory = 0;  // --memory-budget (0: the platform's)
  std::uint32_t twin_paths = 0;  // paths in flight (twin_path_cap)
  std::uint64_t twin_seed = 1;
  PathTraceOptions path_trace;
  ReplayLog recording;                    // record_replay: every split of this run
  std::vector<Fault> faults;              // --fail, checked against the platform
};

// The twin file and its ray log, checked against each other.
void load_twin_inputs(const SimulationConfig& cfg, Inputs& in) {
  in.twin = load_twin(cfg.workload);
  const std::string rays = in.twin.rays_path(cfg.workload);
  auto log = std::make_shared<RayLog>(RayLog::load(rays));
  if (log->cells != in.twin.blocks.size())
    throw InputError(rays, "cells", std::to_string(log->cells) + " cells, but " + cfg.workload + " lists " +
                                        std::to_string(in.twin.blocks.size()) + " blocks");
  if (log->width != in.twin.width || log->height != in.twin.height || log->spp != in.twin.spp)
    throw InputError(rays, "width", "the ray log's image (" + std::to_string(log->width) + "x" +
                                        std::to_string(log->height) + ", " + std::to_string(log->spp) +
                                        " spp) is not the twin file's");
  in.twin_rays = std::move(log);
  in.host_memory = static_cast<Bytes>(cfg.host_memory);
  if (cfg.fidelity == Fidelity::Analytic)
    throw InputError("--fidelity", "", "a recorded render's twin runs at replay (its ray log) or markov (the log's statistics)");
  in.twin_fidelity = cfg.fidelity;
  in.twin_seed = cfg.seed;
}

// The paths a twin keeps in flight: the recorded render's, or under another budget
// (--memory-budget) what the renderer would keep there (paths_in_budget).
std::uint32_t twin_path_cap(const Inputs& in) {
  const TwinSpec& t = in.twin;
  if (in.host_memory == 0) return t.path_cap;
  const Bytes largest = *std::max_element(t.blocks.begin(), t.blocks.end());
  const int depth = static_cast<int>(t.max_depth);
  if (in.host_memory < largest + 64 * path_bytes(depth))
    throw InputError("--memory-budget", "", "smaller than the recorded render's largest block (" + std::to_string(largest) +
                                                " bytes) plus room for 64 paths of rays");
  return paths_in_budget(in.host_memory, largest, depth, Bytes(t.width) * t.height * t.spp);
}

// The twin runs on one machine's DCG as the renderer builds it: a disk and a host memory,
// compute devices running RayIntersect and ShadowIntersect.
void check_twin_platform(const SimulationConfig& cfg, const Inputs& in) {
  const DeviceGraph& g = in.graph;
  const std::string file = cfg.platform_file.empty() ? cfg.workload : cfg.platform_file;
  bool disk = false, host = false;
  for (const MemoryDevice& m : g.memories) disk |= m.kind == MemoryKind::Disk, host |= m.kind == MemoryKind::Host;
  if (!disk || !host) throw InputError(file, "memory", "the twin of a render needs a disk and a host memory device");
  if (g.job_type("RayIntersect") == kNone || g.job_type("ShadowIntersect") == kNone)
    throw InputError(file, "compute", "the twin of a render needs devices running RayIntersect and ShadowIntersect");
}

std::unique_ptr<Inputs> load_inputs(const SimulationConfig& cfg) {
  auto in = std::make_unique<Inputs>();  // (path_trace.record points into it)
  if (cfg.workload_kind == WorkloadKind::Twin) load_twin_inputs(cfg, *in);
  if (cfg.twin_fitted_timing && in->twin.fitted_platform_json.empty())
    throw InputError(cfg.workload, "fitted_platform", "missing: --timing recorded needs a twin file that has it");
  in->graph = !cfg.platform_file.empty()  ? load_platform(cfg.platform_file)
              : cfg.twin_fitted_timing    ? parse_platform(in->twin.fitted_platform_json, cfg.workload + " (its fitted_platform)")
                                          : parse_platform(in->twin.platform_json, cfg.workload + " (its platform)");
  if (cfg.workload_kind == WorkloadKind::Twin) {
    check_twin_platform(cfg, *in);
    in->twin_paths = twin_path_cap(*in);
  }
  if (cfg.host_memory > 0) {  // --memory-budget: the RAM of every node, as a render's budget
    for (MemoryDevice& m : in->graph.memories)
      if (m.kind == MemoryKind::Host) m.capacity = static_cast<Bytes>(cfg.host_memory);
    in->graph.source_file += " (host memory from --memory-budget)";
  }
  for (const std::string& f : cfg.faults) in->faults.push_back(parse_fault(f, in->graph));
  std::stable_sort(in->faults.begin(), in->faults.end(), [](const Fault& a, const Fault& b) { return a.at < b.at; });
  if (cfg.workload_kind == WorkloadKind::JobSet) in->set = std::make_unique<JobSet>(load_job_set(cfg.workload, in->graph));
  if (cfg.workload_kind == WorkloadKind::PathTrace) {
    in->profile = std::make_unique<SceneProfile>(load_scene_profile(cfg.workload));
    PathTraceOptions& pto = in->path_trace;
    pto.fidelity = cfg.fidelity;
    if (pto.fidelity == Fidelity::Replay)
      pto.replay = std::make_shared<ReplayLog>(ReplayLog::load(cfg.replay_file, in->profile.get()));
    pto.clients = cfg.clients;
    pto.prediction_depth = cfg.prediction_depth;
    pto.merge_planned = cfg.merge_planned;
    pto.cancel_failed = cfg.cancel_failed;
    pto.warm = cfg.warm;
    if (cfg.warm) {  // the policy's own steady-state placement, where it has one
      std::vector<Bytes> bytes;
      for (const ProfileBlock& b : in->profile->blocks) bytes.push_back(b.bytes);
      pto.warm_start.placement = warm_placement(cfg.scheduler, in->graph, bytes);
    }
    pto.job_bytes_cap = job_caps(cfg.scheduler, in->graph);  // the policy's device-sized jobs, if any
    pto.frames_in_flight = cfg.frames_in_flight;
    pto.frames_per_client = cfg.frames_per_client;
    pto.retime_merged = cfg.retime_merged;
    pto.seed = cfg.seed;
    if (cfg.record_replay) pto.record = &in->recording;
  }
  return in;
}

// The run's results are written into OUT.partial.<pid>@<host>/ and renamed to OUT only
// once complete (common/output_folder.hpp); an unpublished partial folder is removed.
class PartialFolder {
 public:
  explicit PartialFolder(const std::string& out_dir)
      : out_dir_(out_dir), out_(replaceable_folder(out_dir, "", kRunFiles)), path_(partial_folder(out_)),
        unfinished_guard_(path_.string()) {  // removed if the run is interrupted
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
    std::filesystem::create_directories(path_, ec);
    if (ec) throw InputError(out_dir, "", "cannot create output directory: " + ec.message());
  }
  ~PartialFolder() {
    std::error_code ec;
    if (!published_) std::filesystem::remove_all(path_, ec);
  }
  PartialFolder(const PartialFolder&) = delete;
  PartialFolder& operator=(const PartialFolder&) = delete;
  std::filesystem::path operator/(const std::string& file) const { return path_ / file; }
  // Writes `file` into the partial folder. A failure names the file as the user will look
  // for it, under OUT, and says why; the stream is closed before the check, since the
  // last buffered bytes reach the disk (and a full disk shows) only then.
  template <class Write>
  void write(const std::string& file, const Write& write) const {
    std::ofstream out(path_ / file, std::ios::binary | std::ios::trunc);
    write(out);
    out.close();
    if (!out) {
      const int err = errno;
      throw std::runtime_error("cannot write " + (std::filesystem::path(out_) / file).string() +
                               (err != 0 ? std::string(": ") + std::strerror(err) : std::string()));
    }
  }
  void publish() {
    replaceable_folder(out_dir_, "", kRunFiles);  // again: the user may have put a file there meanwhile
    publish_folder(path_.string(), out_, "");
    published_ = true;
  }

 private:
  std::string out_dir_, out_;
  std::filesystem::path path_;
  unfinished::Guard unfinished_guard_;
  bool published_ = false;
};

SgOptions sg_options(const SimulationConfig& cfg, const PartialFolder& folder) {
  SgOptions sgo;
  // Device timelines run one exec at a time; a Paje trace still shows them as SimGrid execs.
  sgo.exclusive_execs = !cfg.paje;
  if (cfg.paje)
    sgo.config = {"tracing:yes", "tracing/uncategorized:yes", "tracing/precision:9",
                  "tracing/filename:" + (folder / "simgrid.trace").string()};
  return sgo;
}

// Actual E-job durations: predicted x U[1-n, 1+n] per activity (a hash of seed and id, so
// a run is reproducible), and for path tracing the real size of jobs planned from
// predictions before their rays were known.
SimExecutorOptions executor_options(const SimulationConfig& cfg, const PathTraceWorkload* pt) {
  SimExecutorOptions xo;
  xo.transfer_order = cfg.transfer_order;
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
  if (pt) {
    auto noise = xo.exec_factor;
    xo.exec_factor = [pt, noise](ActivityId id, const Activity& a) {
      return pt->exec_scale(a.job, a.device, a) * (noise ? noise(id, a) : 1.0);
    };
  }
  return xo;
}

// The simulated system: SimGrid platform, schedule, workload, scheduler and SimExecutor
// under the runtime loop (docs/architecture.md, control loop).
struct Engine {
  Engine(const SimulationConfig& cfg, Inputs& in, const PartialFolder& folder)
      : platform(in.graph, sg_options(cfg, folder)),
        pool(in.set ? in.set->pool : own_pool),
        schedule(in.graph, pool),
        workload(make_workload(cfg, in)),
        scheduler(make_scheduler(cfg.scheduler)),
        executor(platform, schedule, executor_options(cfg, path_trace)),
        loop(*scheduler, executor, *workload, pool, schedule) {
    for (const Fault& f : in.faults) loop.add_fault(f);
    if (path_trace && scheduler->places_ray_origins())  // Rayline's rule 8
      path_trace->set_ray_origin([this](std::uint64_t wave, BlockId entry) { return scheduler->ray_origin(wave, entry, pool, schedule); });
    loop.on_fault = [this](const Fault& f, const RunStats& st) { faults.push_back({f, st, executor.now()}); };
    // A render's loop makes the first wave of camera rays before its first plan
    // (ControlLoop::per_camera_ray); the twin's first dispatch waits for it.
    if (const Time per_ray = in.graph.loop.per_camera_ray; twin && per_ray > 0)
      executor.hold_first_dispatch([this, per_ray] { return double(twin->first_wave()) * per_ray; });
  }

  std::unique_ptr<Workload> make_workload(const SimulationConfig& cfg, Inputs& in) {
    switch (cfg.workload_kind) {
      case WorkloadKind::PathTrace: {
        auto w = std::make_unique<PathTraceWorkload>(in.graph, *in.profile, in.path_trace);
        path_trace = w.get();
        return w;
      }
      case WorkloadKind::RayStream: {
        RayStreamOptions ro;
        ro.blocks = cfg.blocks;
        ro.seed = cfg.seed;
        ro.warm = cfg.warm;
        auto w = std::make_unique<RayStreamWorkload>(in.graph, ro);
        stream = w.get();
        return w;
      }
      case WorkloadKind::Twin: return make_twin(in);
      case WorkloadKind::JobSet: break;
    }
    for (auto [b, m] : in.set->initial) schedule.put_initial(b, m);
    return std::make_unique<StaticWorkload>();
  }

  // The render's blocks on the disk(s), its rays queued in the first host memory (renderer.cpp
  // does the same, one node per rank in a distributed render).
  std::unique_ptr<Workload> make_twin(const Inputs& in) {
    const DeviceGraph& g = in.graph;
    MemId ram = kNone;
    for (std::size_t i = 0; i < g.memories.size(); ++i)
      if (g.memories[i].kind == MemoryKind::Host && ram == kNone) ram = MemId(i);
    std::vector<BlockId> blocks;
    for (std::size_t c = 0; c < in.twin.blocks.size(); ++c) {
      DataBlock d;
      d.name = "scene" + std::to_string(c);
      d.kind = DataKind::SceneData;
      d.bytes = in.twin.blocks[c];
      blocks.push_back(pool.add_block(d));
      for (std::size_t m = 0; m < g.memories.size(); ++m)  // every node's disk (a cluster: as a distributed render)
        if (g.memories[m].kind == MemoryKind::Disk) schedule.put_initial(blocks.back(), MemId(m), 0, true);
    }
    RayBatchOptions o;
    o.spp = int(in.twin.spp);
    o.path_cap = in.twin_paths;
    o.min_batch = in.twin.min_batch;
    o.max_batch = in.twin.max_batch;
    o.continue_in_cell = in.twin.continue_in_cell;
    o.camera_jobs = in.twin.camera_jobs;
    std::unique_ptr<TwinOracle> oracle;
    if (in.twin_fidelity == Fidelity::Replay)
      oracle = std::make_unique<ReplayOracle>(in.twin_rays);
    else
      oracle = std::make_unique<MarkovOracle>(*in.twin_rays, in.twin.width, in.twin.height, in.twin.spp, in.twin_seed);
    auto w = std::make_unique<RenderTwinWorkload>(g, ram, std::move(blocks), o, std::move(oracle));
    twin = w.get();
    return w;
  }

  SgPlatform platform;
  JobPool own_pool;
  JobPool& pool;
  Schedule schedule;
  RayStreamWorkload* stream = nullptr;
  PathTraceWorkload* path_trace = nullptr;
  RenderTwinWorkload* twin = nullptr;
  std::unique_ptr<Workload> workload;
  std::unique_ptr<Scheduler> scheduler;
  SimExecutor executor;
  RuntimeLoop loop;
  struct Applied {
    Fault fault;
    RunStats after;  // the loop's counters right after it
    Time at;
  };
  std::vector<Applied> faults;
};

void show_progress(const SimulationConfig& cfg, Engine& e, ProgressLine& progress) {
  if (progress.mode() == ProgressLine::Mode::Off) return;
  e.loop.on_progress = [&cfg, &e, &progress](Time now, const RunStats&) {
    if (!progress.due()) return;
    const double rays = e.stream       ? static_cast<double>(e.stream->rays_traced())
                        : e.path_trace ? static_cast<double>(work_of(*e.path_trace))
                        : e.twin       ? static_cast<double>(e.twin->counts().traced)
                                       : 0.0;
    if (cfg.runs_for_duration())
      progress.print("simulate", "t=%7.2f / %.0f s  rays %.3g  activities %zu", now, cfg.duration, rays,
                     e.schedule.activity_count());
    else
      progress.print("simulate", "t=%7.2f s  jobs left %zu  activities %zu", now, e.pool.queued_count(),
                     e.schedule.activity_count());
  };
}

// ---- run -----------------------------------------------------------------------------

struct Outcome {
  RunStats stats;
  bool stalled = false;
  Time end = 0;          // the simulated span the metrics cover
  double run_wall = 0;   // wall seconds in the runtime loop
};

Outcome run_engine(const SimulationConfig& cfg, Engine& e) {
  ProgressLine progress(cfg.progress);
  show_progress(cfg, e, progress);
  const auto run0 = std::chrono::steady_clock::now();
  Outcome o;
  o.stats = e.loop.run(cfg.runs_for_duration() ? cfg.duration : kNever);
  // A stream never drains, so the loop cannot see a stall; a queued job that no device can
  // ever run (too big for every memory device, no path) is one all the same: any queued
  // job, not only the oldest (the rays it holds are lost either way).
  o.stalled = o.stats.stalled || first_unplaceable(e.pool, e.schedule) != kNone;
  o.run_wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - run0).count();
  e.loop.on_progress = nullptr;
  progress.done();
  o.end = cfg.runs_for_duration() ? cfg.duration : o.stats.makespan;
  // --frames: the run ends with its last frame (the makespan), if that came before --duration.
  if (e.path_trace && cfg.frames_per_client > 0 && e.path_trace->finished()) {
    Time last = 0;
    for (const FrameReport& f : e.path_trace->frames()) last = std::max(last, f.delivered);
    if (last > 0) o.end = std::min(o.end, last);
  }
  return o;
}

// ---- report --------------------------------------------------------------------------

// Plan vs reality for the whole run: the latest planned end of what finished, and when it
// actually finished (static job sets: the predicted and the measured makespan).
json makespan_metrics(const Schedule& s) {
  Time planned_ms = 0, actual_ms = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.state != ActivityState::Done || a.cancelled) continue;
    planned_ms = std::max(planned_ms, a.planned_end);
    actual_ms = std::max(actual_ms, a.end);
  }
  return {{"planned", planned_ms}, {"actual", actual_ms}, {"gap", actual_ms - planned_ms}};
}

// Finished and withdrawn activities, the work done (per simulated second too) and the
// relative error of the predicted durations.
struct ActivityTally {
  std::uint64_t done_exec = 0, done_transfer = 0, cancelled_exec = 0, cancelled_transfer = 0;
  std::vector<double> err_exec, err_transfer;
  double work_done = 0;
  std::vector<double> per_second;
};

ActivityTally tally_activities(const Schedule& s, const JobPool& pool, Time end) {
  ActivityTally n;
  n.per_second.assign(static_cast<std::size_t>(std::ceil(std::max<Time>(end, 1e-9))), 0.0);
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.cancelled) {  // withdrawn predictions (Sec. 5.2): no work, no error sample
      ++(a.kind == ActivityKind::Exec ? n.cancelled_exec : n.cancelled_transfer);
      continue;
    }
    if (a.state != ActivityState::Done) continue;
    const double actual = a.end - a.start;
    const double rel = a.duration > 0 ? std::abs(actual - a.duration) / a.duration : 0;
    if (a.kind == ActivityKind::Exec) {
      ++n.done_exec;
      n.err_exec.push_back(rel);
      const double w = static_cast<double>(pool.job(a.job).work);
      n.work_done += w;
      const auto bin = std::min(n.per_second.size() - 1, static_cast<std::size_t>(std::max(0.0, a.end)));
      n.per_second[bin] += w;
    } else {
      ++n.done_transfer;
      n.err_transfer.push_back(rel);
    }
  }
  return n;
}

// How long E-jobs waited in the global queue before they ran (start - created; Sec. 4.3's
// starvation shows as a long tail), and the longest wait of a job still queued at the end.
json queue_wait_metrics(const Schedule& s, const JobPool& pool, Time end) {
  std::vector<double> waits;
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (a.kind == ActivityKind::Exec && !a.cancelled && a.state == ActivityState::Done)
      waits.push_back(std::max(0.0, a.start - pool.job(a.job).created));
  }
  double oldest_queued = 0;
  for (JobId j : pool.queued()) oldest_queued = std::max(oldest_queued, end - pool.job(j).created);
  return {{"mean", mean_of(waits)}, {"p50", percentile(waits, 0.5)}, {"p95", percentile(waits, 0.95)},
          {"max", waits.empty() ? 0.0 : *std::max_element(waits.begin(), waits.end())},
          {"oldest_queued_at_end", oldest_queued}};
}

// Per compute device and per kind of device: busy, setup, fetching and true idle time
// (Sec. 4.2's split); returns the sums per kind.
std::map<std::string, DeviceTime> device_metrics(json& m, const Schedule& s, Time end) {
  const DeviceGraph& g = s.graph();
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
  return by_kind;
}

// Channel utilisation: bytes moved (exact SimGrid integral) / (bandwidth x time).
void resource_metrics(json& m, const SgPlatform& platform, Time end) {
  const DeviceGraph& g = platform.graph();
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
}

// The process's peak resident set so far (getrusage: kilobytes on Linux), in MB.
double peak_rss_mb() {
  rusage u{};
  return getrusage(RUSAGE_SELF, &u) == 0 ? static_cast<double>(u.ru_maxrss) / 1024.0 : 0.0;
}

// Where the time goes: SimGrid (solver + event queue) = the run minus our callbacks; the
// scheduler (plan calls); bookkeeping (runtime loop, executor, workload).
json simulator_metrics(const Outcome& o, double in_callbacks, double wall, std::uint64_t activities) {
  const double sched = o.stats.scheduler_wall_seconds;
  return {{"wall_s", wall},
          {"run_wall_s", o.run_wall},
          {"simgrid_s", std::max(0.0, o.run_wall - in_callbacks)},
          {"scheduler_s", sched},
          {"bookkeeping_s", std::max(0.0, in_callbacks - sched)},
          {"setup_and_metrics_s", std::max(0.0, wall - o.run_wall)},
          {"speedup_vs_simulated", wall > 0 ? o.end / wall : 0},
          {"activities_per_wall_s", wall > 0 ? static_cast<double>(activities) / wall : 0},
          {"peak_rss_mb", peak_rss_mb()}};
}

// The faults of --fail (docs/faults.md): what each took, and the throughput before and
// after it (rays intersected per simulated second for path tracing, work units otherwise).
json fault_metrics(const Engine& e, const Inputs& in, const Outcome& o, Time end, SimulationSummary& sum) {
  const DeviceGraph& g = e.schedule.graph();
  json list = json::array();
  std::uint64_t aborted = 0, requeued = 0, lost = 0;
  for (const Engine::Applied& a : e.faults) {
    json devices = json::array();
    for (DeviceId d : a.fault.computes) devices.push_back(g.computes[static_cast<std::size_t>(d)].name);
    for (MemId m : a.fault.memories) devices.push_back(g.memories[static_cast<std::size_t>(m)].name);
    // Work done in [from, to) per second: path tracing pro rata over each job's run; other workloads: the activities that finished then.
    auto rate = [&](Time from, Time to) {
      double w = 0;
      if (e.path_trace) {
        for (const RaySpan& r : e.path_trace->traced()) w += r.within(from, to);
      } else {
        for (std::size_t i = 0; i < e.schedule.activity_count(); ++i) {
          const Activity& x = e.schedule.activity(static_cast<ActivityId>(i));
          if (x.kind == ActivityKind::Exec && x.state == ActivityState::Done && x.end >= from && x.end < to)
            w += static_cast<double>(e.pool.job(x.job).work);
        }
      }
      return to > from ? w / (to - from) : 0.0;
    };
    list.push_back({{"fail", a.fault.what}, {"at_s", a.at}, {"lost", devices},
                    {"activities_aborted", a.after.aborted - aborted}, {"jobs_queued_again", a.after.requeued - requeued},
                    {"jobs_lost", a.after.lost_jobs - lost},
                    {"rays_per_second_before", rate(0, a.at)}, {"rays_per_second_after", rate(a.at, end)}});
    aborted = a.after.aborted;
    requeued = a.after.requeued;
    lost = a.after.lost_jobs;
  }
  json j;
  j["applied"] = list;
  // Faults whose time the run never reached (it ended first): listed, not silently dropped.
  json later = json::array();
  for (std::size_t i = e.faults.size(); i < in.faults.size(); ++i) later.push_back(in.faults[i].what);
  j["not_reached"] = later;
  j["failed_activities_retried"] = o.stats.retried;
  sum.faults_applied = static_cast<int>(e.faults.size());
  if (e.stream) {
    j["rays_lost"] = e.stream->rays_lost();
    sum.rays_lost = e.stream->rays_lost();
  }
  if (e.path_trace) {
    j["rays_lost"] = e.path_trace->tally().lost;
    j["frames_abandoned"] = e.path_trace->abandoned_frames().size();
    sum.rays_lost = e.path_trace->tally().lost;
    sum.frames_abandoned = e.path_trace->abandoned_frames().size();
  }
  return j;
}

// A path-tracing run in which no ray ended after the warm-up: why, from what was running at
// the end (usually first E-jobs longer than the run: a whole wave of primary rays in one
// queue on one device), and what to change.
std::string why_nothing_ended(const Engine& e, Time warm, Time end) {
  Time longest = 0, longest_start = 0;
  std::size_t running = 0;
  std::string device;
  for (std::size_t i = 0; i < e.schedule.activity_count(); ++i) {
    const Activity& a = e.schedule.activity(static_cast<ActivityId>(i));
    // (Running, or started without its start reported yet: SimExecutor hands starts over with
    // the next batch, and the run may end before one comes.)
    if (a.kind != ActivityKind::Exec || a.cancelled || a.state == ActivityState::Done || a.state == ActivityState::Failed ||
        a.start > end)
      continue;
    ++running;
    if (a.duration > longest) {
      longest = a.duration;
      longest_start = a.start;
      device = e.schedule.graph().computes[static_cast<std::size_t>(a.device)].name;
    }
  }
  char buf[512];
  if (running > 0)
    std::snprintf(buf, sizeof buf,
                  "no ray ended after the warm-up (%.3g s of %.3g s): %zu E-job(s) unfinished at the end, the longest "
                  "on %s from %.3g s, planned for %.3g s; try a --duration of at least %.3g s, or --start warm",
                  warm, end, running, device.c_str(), longest_start, longest, 3 * (longest_start + longest));
  else
    std::snprintf(buf, sizeof buf,
                  "no ray ended after the warm-up (%.3g s of %.3g s), and no E-job had started by the end: the devices "
                  "were waiting for data (see device_summary); try a longer --duration or --start warm",
                  warm, end);
  return buf;
}

// The twin of a render: its frame against the recording's (docs/validation.md). Loads are
// the disk->RAM T-jobs of scene blocks, as the renderer's block store counts them.
json twin_metrics(const SimulationConfig& cfg, const Engine& e, const Inputs& in, const Outcome& o, SimulationSummary& sum) {
  std::uint64_t loads = 0;
  Bytes bytes = 0;
  for (std::size_t i = 0; i < e.schedule.activity_count(); ++i) {
    const Activity& a = e.schedule.activity(static_cast<ActivityId>(i));
    if (a.kind != ActivityKind::Transfer || a.state != ActivityState::Done || a.cancelled) continue;
    if (e.pool.block(a.block).kind != DataKind::SceneData) continue;
    const Channel& ch = e.schedule.graph().channels[static_cast<std::size_t>(a.channel)];
    if (e.schedule.graph().memories[std::size_t(ch.from)].kind != MemoryKind::Disk ||
        e.schedule.graph().memories[std::size_t(ch.to)].kind != MemoryKind::Host)
      continue;
    ++loads;
    bytes += a.bytes;
  }
  const RenderTwinWorkload& w = *e.twin;
  sum.twin = true;
  sum.twin_loads = loads;
  sum.twin_jobs = w.jobs_created();
  sum.recorded_loads = in.twin.recorded_loads;
  sum.recorded_jobs = in.twin.recorded_jobs;
  sum.recorded_seconds = in.twin.recorded_seconds;
  const bool done = w.finished() && !o.stalled;
  return {{"scene", in.twin.scene},
          {"fidelity", to_string(in.twin_fidelity)},
          {"timing", !cfg.platform_file.empty() ? "platform file" : cfg.twin_fitted_timing ? "recorded" : "platform"},
          {"frame_done", done},
          {"makespan_s", o.stats.makespan},
          {"loads", loads},
          {"bytes_loaded", bytes},
          {"jobs", w.jobs_created()},
          {"merges", w.merges()},
          {"block_visits", w.counts().traced},
          {"camera_rays", w.camera_rays()},
          {"paths_ended", w.counts().paths_ended},
          {"recorded_run", {{"seconds", in.twin.recorded_seconds},
                            {"loads", in.twin.recorded_loads},
                            {"jobs", in.twin.recorded_jobs},
                            {"block_visits", in.twin.recorded_traced}}}};
}

// metrics.json (its fields: docs/architecture.md); fills the summary's totals.
json run_metrics(const SimulationConfig& cfg, const Inputs& in, const Engine& e, const Outcome& o, double wall,
                 SimulationSummary& sum) {
  const Time end = o.end;
  json m;
  if (!invocation_command().empty())
    m["rayline"] = {{"version", invocation_version()}, {"command", invocation_command()}};
  m["platform"] = in.graph.name;
  m["platform_file"] = cfg.platform_file;
  if (cfg.host_memory > 0) m["host_memory_bytes"] = cfg.host_memory;
  m["workload"] = cfg.workload;
  m["scheduler"] = std::string(scheduler_name(cfg.scheduler.kind));
  m["scheduler_parameters"] = e.scheduler->describe();
  m["horizon_s"] = cfg.scheduler.horizon;
  m["transfer_order"] = std::string(to_string(cfg.transfer_order));
  m["seed"] = cfg.seed;
  m["start"] = cfg.warm ? "warm" : "cold";
  m["simulated_s"] = end;
  m["makespan_s"] = makespan_metrics(e.schedule);
  m["stalled"] = o.stalled;
  const ActivityTally n = tally_activities(e.schedule, e.pool, end);
  m["queue_wait_s"] = queue_wait_metrics(e.schedule, e.pool, end);
  m["work_units_done"] = n.work_done;
  m["rays_per_second"] = end > 0 ? n.work_done / end : 0;
  m["rays_per_second_series"] = n.per_second;
  m["activities"] = {{"e_jobs_done", n.done_exec}, {"t_jobs_done", n.done_transfer},
                     {"committed", e.schedule.activity_count()}, {"evictions", e.schedule.evictions().size()},
                     {"queued_at_end", e.pool.queued_count()}, {"e_jobs_cancelled", n.cancelled_exec},
                     {"t_jobs_cancelled", n.cancelled_transfer}};
  if (e.stream) m["activities"]["queue_merges"] = e.stream->merges();
  if (e.path_trace) {
    path_trace_metrics(m, *e.path_trace, *in.profile, cfg, end, sum);
    if (const MemId cm = e.path_trace->client_memory(); cm != kNone) {
      const MemoryDevice& md = e.schedule.graph().memories[static_cast<std::size_t>(cm)];
      sum.client_memory = md.name;
      sum.client_framebuffer_bytes = static_cast<double>(e.path_trace->client_framebuffer_bytes());
      sum.client_memory_capacity = static_cast<double>(md.capacity);
      m["path_trace"]["client_framebuffers"] = {{"memory", md.name},
                                                {"bytes", e.path_trace->client_framebuffer_bytes()},
                                                {"share_of_memory", sum.client_framebuffer_bytes / std::max(1.0, sum.client_memory_capacity)}};
    }
    bound_metrics(m["path_trace"], e.schedule.graph(), *in.profile, e.path_trace->model().fidelity(), sum);
    if (sum.steady_rays_shot_per_second <= 0) {
      sum.nothing_delivered = why_nothing_ended(e, cfg.warmup >= 0 ? cfg.warmup : end / 3, end);
      m["path_trace"]["nothing_delivered"] = sum.nothing_delivered;
    }
  }
  if (e.twin) m["twin"] = twin_metrics(cfg, e, in, o, sum);
  m["prediction_error"] = {{"exec_mean_rel", mean_of(n.err_exec)}, {"exec_p95_rel", percentile(n.err_exec, 0.95)},
                           {"transfer_mean_rel", mean_of(n.err_transfer)},
                           {"transfer_p95_rel", percentile(n.err_transfer, 0.95)}};
  const std::map<std::string, DeviceTime> by_kind = device_metrics(m, e.schedule, end);
  resource_metrics(m, e.platform, end);
  m["scheduler_cost"] = {{"wall_s", o.stats.scheduler_wall_seconds}, {"plan_calls", o.stats.plan_calls},
                         {"share_of_simulated_time", end > 0 ? o.stats.scheduler_wall_seconds / end : 0}};
  m["simulator"] = simulator_metrics(o, e.executor.callback_wall_seconds(), wall, n.done_exec + n.done_transfer);
  if (!in.faults.empty()) m["faults"] = fault_metrics(e, in, o, end, sum);
  sum.rays_per_second = end > 0 ? n.work_done / end : 0;
  sum.activities = n.done_exec + n.done_transfer;
  double tot = 0;
  for (const auto& [k, t] : by_kind) tot += t.busy + t.setup + t.fetching + t.idle;
  for (const auto& [k, t] : by_kind) {
    sum.busy += t.busy / std::max(tot, 1e-300);
    sum.setup += t.setup / std::max(tot, 1e-300);
    sum.fetching += t.fetching / std::max(tot, 1e-300);
    sum.idle += t.idle / std::max(tot, 1e-300);
  }
  return m;
}

void write_results(const SimulationConfig& cfg, const Inputs& in, const Engine& e, const json& m,
                   const PartialFolder& folder) {
  folder.write("metrics.json", [&](std::ostream& out) { out << m.dump(2) << "\n"; });
  folder.write("jobs.csv", [&](std::ostream& out) { write_jobs_csv(e.schedule, out); });
  if (cfg.timeline)
    folder.write("timeline.json", [&](std::ostream& out) { write_chrome_trace(e.schedule, true, out); });
  if (cfg.record_replay)
    in.recording.save((folder / "replay.log").string(),
                      "scene=" + in.profile->name + " fidelity=" + to_string(cfg.fidelity) +
                          " seed=" + std::to_string(cfg.seed) + " clients=" + std::to_string(cfg.clients));
}

}  // namespace

void check_results_folder(const std::string& dir, const std::string& flag) { replaceable_folder(dir, flag, kRunFiles); }

SimulationSummary run_simulation(const SimulationConfig& cfg) {
  const auto wall0 = std::chrono::steady_clock::now();
  const std::unique_ptr<Inputs> in = load_inputs(cfg);
  PartialFolder folder(cfg.out_dir);
  Engine engine(cfg, *in, folder);
  const Outcome o = run_engine(cfg, engine);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  SimulationSummary sum;
  const json m = run_metrics(cfg, *in, engine, o, wall, sum);
  write_results(cfg, *in, engine, m, folder);
  folder.publish();
  sum.simulated = o.end;
  sum.wall_seconds = wall;
  sum.scheduler_seconds = o.stats.scheduler_wall_seconds;
  sum.stalled = o.stalled;
  sum.queued_at_end = engine.pool.queued_count();
  if (o.stalled) sum.stalled_reason = unplaced_summary(engine.pool, engine.schedule);
  return sum;
}

}  // namespace rayline::sim

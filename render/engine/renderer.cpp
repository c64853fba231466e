#include "render/engine/renderer.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <thread>

#include "common/error.hpp"
#include "render/engine/activity_tasks.hpp"
#include "render/engine/aggregate_factory.hpp"
#include "render/engine/gpu_select.hpp"
#include "render/engine/local_executor.hpp"
#include "render/engine/profile_recorder.hpp"
#include "render/engine/ray_log_recorder.hpp"
#include "render/engine/render_metrics.hpp"
#include "render/engine/workstation.hpp"
#include "render/integrator/camera.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"
#include "render/scene/scene_stream.hpp"
#include "render/store/temp_partition.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/io/trace_output.hpp"
#include "sched/policy/scheduler_factory.hpp"
#include "sched/policy/unplaced.hpp"

namespace rayline::engine {

namespace fs = std::filesystem;

namespace {

// Resident-set size now (/proc/self/statm) and the process's peak (getrusage).
Bytes rss_now() {
  long pages = 0, resident = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return Bytes(resident) * Bytes(::sysconf(_SC_PAGESIZE));
}
Bytes rss_peak() {
  struct rusage ru {};
  ::getrusage(RUSAGE_SELF, &ru);
  return Bytes(ru.ru_maxrss) * 1024;
}


std::uint32_t auto_blocks(std::uint64_t triangles, Bytes budget) {
  const double fp = double(BlockStore::footprint_of(triangles, trace::BvhQuality::Low));
  if (budget == 0) return std::uint32_t(std::clamp<double>(std::ceil(double(triangles) / 4e6), 1, 64));
  // At least four blocks resident at once, and a few cells to balance the threads. Blocks
  // of at most ~160 k triangles: every load pays a BVH build (≈ 12 ms for 160 k triangles
  // with the low-quality builder on the 2-core development VM), and out of core the last
  // seconds are many loads for a few straggling rays each (README, "Performance"). On the
  // 10 M-triangle museum at a 25 % budget: 16 blocks (four resident) 14.5 s, 32 blocks
  // ≈ 13.4 s, 64 blocks ≈ 11.5 s, 128 blocks no better, 256 blocks much worse (1 800 loads,
  // per-job overhead); at 10 %: 32 blocks 23.8 s, 64 blocks ≈ 18.6 s.
  const double by_size = std::ceil(double(triangles) / 160e3);
  return std::uint32_t(std::clamp<double>(std::max(std::ceil(4 * fp / double(budget)), by_size), 8, 1024));
}

// The Vulkan device of --gpu, with the test hook of RenderOptions.
std::unique_ptr<gpu::GpuContext> open_gpu(const RenderOptions& opt, RenderResult& res) {
  auto ctx = select_gpu(opt.gpu, res.gpu_status);
  if (!ctx) return nullptr;
  res.gpu_device = ctx->info().name;
  res.gpu_cpu_backed = ctx->info().cpu_backed;
  if (opt.gpu_fault_after > 0)
    ctx->inject_fault(opt.gpu_fault_after,
                      opt.gpu_fault == "oom" ? gpu::GpuErrorKind::OutOfMemory : gpu::GpuErrorKind::DeviceLost);
  return ctx;
}

// ---- setup: what the options resolve to ----------------------------------------------

struct Frame {
  scene::Scene sc;
  trace::BvhQuality quality = trace::BvhQuality::Medium;
  int threads = 1;
};

trace::BvhQuality bvh_quality(const RenderOptions& opt) {
  trace::BvhQuality quality = opt.memory_budget > 0 ? trace::BvhQuality::Low : trace::BvhQuality::Medium;
  if (opt.bvh_quality == "low") quality = trace::BvhQuality::Low;
  else if (opt.bvh_quality == "medium") quality = trace::BvhQuality::Medium;
  else if (opt.bvh_quality == "high") quality = trace::BvhQuality::High;
  else if (opt.bvh_quality != "auto" && !opt.bvh_quality.empty())
    throw InputError("--bvh-quality", "", "unknown quality '" + opt.bvh_quality + "' (auto, low, medium, high)");
  return quality;
}

// The scene, the image, the BVH quality and the compute threads.
void resolve_frame(const RenderOptions& opt, Frame& f, RenderResult& res) {
  f.sc = opt.scene.empty() ? scene::default_scene() : scene::load_scene(opt.scene);
  res.scene_name = opt.scene.empty() ? "<built-in>" : opt.scene;
  const scene::Camera& cam = f.sc.default_camera();
  res.width = opt.width > 0 ? opt.width : cam.width;
  res.height = opt.height > 0 ? opt.height : cam.height;
  res.spp = opt.spp > 0 ? opt.spp : f.sc.render.spp;
  res.max_depth = opt.max_depth > 0 ? opt.max_depth : f.sc.render.max_depth;
  res.seed = opt.seed;
  res.memory_budget = opt.memory_budget;
  if (res.width <= 0 || res.height <= 0 || std::uint64_t(res.width) * std::uint64_t(res.height) > (1ull << 28))
    throw InputError("--resolution", "", "must be positive and at most 2^28 pixels");
  if (std::uint64_t(res.width) * std::uint64_t(res.height) * std::uint64_t(res.spp) >= (1ull << 32))
    throw InputError("--spp", "", "width x height x spp must stay below 2^32 samples");
  f.quality = bvh_quality(opt);
  res.bvh_quality = f.quality == trace::BvhQuality::Low ? "low" : (f.quality == trace::BvhQuality::High ? "high" : "medium");
  f.threads = opt.threads > 0 ? opt.threads
              : opt.cluster ? opt.cluster->default_threads()
                            : std::max(1, int(std::thread::hardware_concurrency()));
  res.threads = f.threads;
}

// ---- setup: blocks on disk ("Blocks on disk") ------------------------------------------

struct Blocks {
  std::optional<TempPartition> tmp;  // the partition's folder when none was given
  std::string dir;
  partition::BlockIndex index;
  std::vector<std::uint64_t> footprint;  // bytes the plan charges per block in RAM
  Bytes largest = 0, largest_triangles = 0;
};

// Partitions the scene into `dir` when it holds no partition yet; an existing partition is
// used as it is, and a different block count is a mistake.
void ensure_partition(const RenderOptions& opt, const scene::Scene& sc, const std::string& dir, RenderResult& res) {
  if (!fs::exists(fs::path(dir) / "blocks.json")) {
    const auto t0 = std::chrono::steady_clock::now();
    partition::PartitionOptions po;
    po.blocks = opt.blocks > 0 ? opt.blocks : auto_blocks(scene::scene_stats(sc).triangles, opt.memory_budget);
    po.out_flag = "--blocks-dir";
    po.memory_limit_flag.clear();
    po.progress = opt.partition_progress;
    partition::partition_scene(sc, dir, po);
    res.partition_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  } else if (opt.blocks > 0) {
    const auto idx = partition::load_block_index(dir);
    if (idx.blocks.size() != opt.blocks)
      throw InputError(dir + "/blocks.json", "blocks",
                       "holds " + std::to_string(idx.blocks.size()) + " blocks but --blocks " +
                           std::to_string(opt.blocks) + " was asked for");
  }
}

// `--bvh-quality auto` in core: the fast Morton builder where the build outweighs the
// tracing, at 4 or more triangles per camera ray. Measured in core with one block: the
// 10 M-triangle museum at 256² × 16 spp (10 triangles per ray) takes 12–18 % less wall time
// with the low-quality BVH; at 512² × 16 spp (2.4) both take the same; the 1 M museum at
// 512² × 16 spp (0.24) takes 15 % more.
void refine_auto_quality(const RenderOptions& opt, const partition::BlockIndex& index, Frame& f, RenderResult& res) {
  if (!(opt.bvh_quality == "auto" || opt.bvh_quality.empty()) || opt.memory_budget > 0) return;
  const std::uint64_t camera_rays = std::uint64_t(res.width) * std::uint64_t(res.height) * std::uint64_t(res.spp);
  if (index.scene_triangles < 4 * camera_rays) return;
  f.quality = trace::BvhQuality::Low;
  res.bvh_quality = "low";
}

void prepare_blocks(const RenderOptions& opt, Frame& f, Blocks& b, RenderResult& res) {
  b.dir = opt.blocks_dir;
  if (b.dir.empty()) b.dir = b.tmp.emplace().path();
  ensure_partition(opt, f.sc, b.dir, res);
  b.index = partition::load_block_index(b.dir);
  refine_auto_quality(opt, b.index, f, res);
  const auto nb = static_cast<std::uint32_t>(b.index.blocks.size());
  res.blocks = nb;
  if (opt.batching.recorder) {  // per-cell statistics of this render
    try {
      opt.batching.recorder->begin(b.index, res.width, res.height, res.spp, res.max_depth);
    } catch (const std::invalid_argument& e) {
      throw InputError("--record-tiles", "", e.what());
    }
  }
  if (opt.batching.ray_log)  // every ray's outcome, for simulate --like
    opt.batching.ray_log->begin(std::uint32_t(res.width), std::uint32_t(res.height), std::uint32_t(res.spp), nb);
  b.footprint.resize(nb);
  for (std::uint32_t i = 0; i < nb; ++i) {
    // Missing or truncated block files are found before anything runs.
    const auto h = partition::read_block_header((fs::path(b.dir) / b.index.blocks[i].file).string());
    b.footprint[i] = BlockStore::footprint_of(h.triangle_count, f.quality);
    b.largest = std::max<Bytes>(b.largest, b.footprint[i]);
    b.largest_triangles = std::max<Bytes>(b.largest_triangles, h.triangle_count);
    res.scene_block_bytes += b.footprint[i];
  }
}

// ---- setup: the platform, this machine --------------------------------------------------

// Bytes of one path's rays: one path ray and at most one shadow ray per hit.
Bytes bytes_per_path(const RenderResult& res) { return path_bytes(res.max_depth); }

// The budget holds scene blocks and the ray queues of queued jobs alike (both are data in
// RAM the plan accounts for). Rays are bounded by the paths alive at once. The path cap is
// lowered so that the largest block plus every ray always fit: the plan can never deadlock
// on memory. Returns the RAM memory device's capacity.
Bytes size_paths(const RenderOptions& opt, const Blocks& b, RenderWorkloadOptions& wo, RenderResult& res) {
  const Bytes per_path = bytes_per_path(res);
  wo.spp = res.spp;
  // path_cap 0 = auto: under a budget, as many paths as the budget can hold next to the
  // largest block (at most the frame's); every path alive is one more ray in each batch,
  // and out of core fewer waves of paths mean fewer rounds of loads over the cells (10 M
  // triangles at a 25 % budget: 131 072 paths 276 loads, all 844 k that fit 142 loads).
  // The plan charges the rays actually queued, so blocks keep the room rays do not use.
  const Bytes frame_paths = Bytes(res.width) * Bytes(res.height) * Bytes(res.spp);
  const bool auto_cap = wo.path_cap == 0;
  if (auto_cap) wo.path_cap = static_cast<std::uint32_t>(std::min<Bytes>(frame_paths, Bytes(1) << 17));
  Bytes ram_capacity = 0;
  if (opt.memory_budget > 0) {
    const Bytes need = b.largest + 64 * per_path;
    if (opt.memory_budget < need)
      throw InputError("--memory-budget", "",
                       "budget of " + std::to_string(opt.memory_budget) + " bytes is smaller than the largest block (" +
                           std::to_string(b.largest) + " bytes in RAM) plus room for 64 paths of rays (" +
                           std::to_string(need) + " bytes in all); use more blocks or a larger budget");
    const Bytes fit = (opt.memory_budget - b.largest) / per_path;
    wo.path_cap = auto_cap ? paths_in_budget(opt.memory_budget, b.largest, res.max_depth, frame_paths)
                           : static_cast<std::uint32_t>(std::min<Bytes>(wo.path_cap, fit));
    ram_capacity = opt.memory_budget;
  } else {
    ram_capacity = res.scene_block_bytes + Bytes(wo.path_cap) * per_path;
  }
  res.path_cap = wo.path_cap;
  return ram_capacity;
}

// The workstation's DCG (Fig. 2) and where its devices are.
struct Platform {
  std::unique_ptr<gpu::GpuContext> gpu_ctx;  // the Vulkan device opened (nullptr: none)
  WorkstationModel wm;
  DeviceGraph g;
  MemId disk = kNone, ram = kNone, gmem = kNone;
  DeviceId gpu_dev = kNone;
  JobTypeId ri = kNone, si = kNone, ric = kNone, sic = kNone;  // the GPU's job types, the CPU-only ones
};

// No GPU: none in the plan. A GPU: the platform file's calibrated timing for it is kept
// (set_gpu seeds the defaults only where the file has none).
void plan_gpu(const RenderOptions& opt, const Blocks& b, const RenderWorkloadOptions& wo, Platform& p,
              RenderResult& res) {
  if (!p.gpu_ctx) {
    set_gpu(p.wm, 0);
    return;
  }
  const Bytes budget = gpu_memory_budget(p.gpu_ctx->info(), opt.gpu_memory_budget);
  // The largest block and one full ray queue must fit, or a GPU job could never be placed.
  const Bytes need = b.largest + Bytes(wo.max_batch) * sizeof(trace::RayRecord);
  if (budget < need)
    throw InputError("--gpu-memory-budget", "",
                     "budget of " + std::to_string(budget) + " bytes is smaller than the largest block plus one ray queue (" +
                         std::to_string(need) + " bytes); use more blocks or a larger budget");
  set_gpu(p.wm, budget);
  res.gpu_memory_budget = budget;
}

// Rays a GPU kernel cannot decide exactly as Embree would come back flagged kRayCpuOnly
// (render/vulkan/README.md, "Doubtful rays") and are queued as these job types, which only
// the CPU devices support, with the CPU's Eq. 2 coefficients: GMB plans them (and the RAM
// copy of their block) like any CPU job, so no sample is lost and nothing unplanned is loaded.
void add_cpu_only_job_types(const RenderOptions& opt, Platform& p) {
  DeviceGraph& g = p.g;
  p.ri = g.job_type("RayIntersect"), p.si = g.job_type("ShadowIntersect");
  p.ric = g.add_job_type("RayIntersectCpu"), p.sic = g.add_job_type("ShadowIntersectCpu");
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    if (g.computes[d].kind == ComputeKind::Cpu) {
      g.timing.at(DeviceId(d), p.ric) = g.timing.at(DeviceId(d), p.ri);
      g.timing.at(DeviceId(d), p.sic) = g.timing.at(DeviceId(d), p.si);
      if (opt.plan_gpu_only) g.timing.at(DeviceId(d), p.ri).supported = g.timing.at(DeviceId(d), p.si).supported = false;
    }
}

void make_platform(const RenderOptions& opt, const Blocks& b, const RenderWorkloadOptions& wo, Bytes ram_capacity,
                   Platform& p, RenderResult& res) {
  // A profile recorder classifies rays in the CPU kernels, and a ray log records CPU visits
  // (a GPU's doubtful rays would come back as visits of their own): no GPU then.
  p.gpu_ctx = opt.batching.recorder || opt.batching.ray_log ? nullptr : open_gpu(opt, res);
  LanModel lan;
  if (opt.cluster) {
    lan = opt.cluster->lan();
    if (opt.platform.empty() || opt.platform == "auto") p.wm = workstation_model(opt.platform);
    else {  // a cluster file (calibrate --distributed): its LAN is the plan's already
      int nodes = 0;
      p.wm = load_node_model(opt.platform, &nodes, &lan);
      if (nodes != opt.cluster->ranks())
        throw InputError(opt.platform, "nodes", "describes " + std::to_string(nodes) + " nodes but " +
                                                    std::to_string(opt.cluster->ranks()) + " ranks run");
    }
    if (opt.platform.empty() || opt.platform == "auto") lan = lan_for_plan(lan, p.wm);
  } else {
    p.wm = opt.model ? *opt.model : workstation_model(opt.platform);
  }
  p.wm.threads = res.threads;
  p.wm.ram_capacity = ram_capacity;
  if (opt.loaders > 0) p.wm.loaders = opt.loaders;
  res.loaders = p.wm.loaders;
  plan_gpu(opt, b, wo, p, res);
  p.g = opt.cluster ? parse_platform(cluster_json(p.wm, opt.cluster->ranks(), lan, "a distributed render"),
                                     "<distributed platform>")
                    : make_workstation(p.wm, opt.platform);
  res.platform = opt.platform.empty() ? "auto" : opt.platform;
  const DeviceGraph& g = p.g;
  for (std::size_t i = 0; i < g.memories.size(); ++i) {
    if (g.memories[i].kind == MemoryKind::Disk && p.disk == kNone) p.disk = MemId(i);
    if (g.memories[i].kind == MemoryKind::Host && p.ram == kNone) p.ram = MemId(i);
    if (g.memories[i].kind == MemoryKind::Gpu && p.gmem == kNone) p.gmem = MemId(i);
  }
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    if (g.computes[d].kind == ComputeKind::Gpu && p.gpu_dev == kNone) p.gpu_dev = DeviceId(d);  // (rank 0's)
  res.gpu_device_id = p.gpu_dev == kNone ? -1 : int(p.gpu_dev);
  if (p.gpu_dev != kNone) add_cpu_only_job_types(opt, p);
}

// ---- run ---------------------------------------------------------------------------------

// The scene blocks in the pool, on disk at the start (Fig. 2's disk memory device).
struct SceneBlocks {
  std::vector<BlockId> blocks;                 // of cell c
  std::map<BlockId, std::uint32_t> cell_of;
};

SceneBlocks add_scene_blocks(const Blocks& b, const DeviceGraph& g, JobPool& pool, Schedule& schedule) {
  SceneBlocks sb;
  sb.blocks.resize(b.footprint.size());
  for (std::uint32_t c = 0; c < b.footprint.size(); ++c) {
    DataBlock d;
    d.name = "scene" + std::to_string(c);
    d.kind = DataKind::SceneData;
    d.bytes = b.footprint[c];
    sb.blocks[c] = pool.add_block(d);
    sb.cell_of[sb.blocks[c]] = c;
    for (std::size_t m = 0; m < g.memories.size(); ++m)  // (a distributed render: on every rank's disk)
      if (g.memories[m].kind == MemoryKind::Disk) schedule.put_initial(sb.blocks[c], MemId(m), 0, true);
  }
  return sb;
}

trace::TraceSettings trace_settings(const RenderOptions& opt, const Frame& f, const Blocks& b, trace::Film& film,
                                    const RenderResult& res) {
  trace::TraceSettings ts;
  ts.scene = &f.sc;
  ts.cells = &b.index;
  ts.set_bounds(b.index.bounds);
  ts.film = &film;
  ts.seed = opt.seed;
  ts.max_depth = res.max_depth;
  // One block: no other cell to go on to, so the walk can spare a ray nothing but one Embree
  // query of the BVH that does the same test faster (in core, 11 % more rays/s without it).
  ts.skip_empty = opt.skip_empty && b.index.blocks.size() > 1;
  ts.continue_in_cell = opt.batching.continue_in_cell;
  return ts;
}

// The aggregate of every compute device (aggregate_factory.hpp), by device id.
std::vector<std::unique_ptr<accel::Aggregate>> make_aggregates(const DeviceGraph& g, const AggregateSources& sources) {
  std::vector<std::unique_ptr<accel::Aggregate>> aggregates;
  for (const auto& c : g.computes) aggregates.push_back(make_aggregate(c.kind, sources));
  return aggregates;
}

// What the run may add beyond the budget (README, "Memory"): the film, ray records in
// flight twice over (staged and in jobs), and a fixed allowance for thread stacks,
// Embree's and the allocator's own state. Loading adds, outside the budget, one staged
// block file (read-ahead) per loader and one block's idle recycled arrays (ArrayPool): 40
// per loader + 52 bytes per triangle of the largest block.
Bytes overhead_bound(const RenderResult& res, const RenderWorkloadOptions& wo, const Blocks& b, const Platform& p) {
  return Bytes(res.width) * Bytes(res.height) * 28 + 2 * Bytes(wo.path_cap) * bytes_per_path(res) +
         b.largest_triangles * (40 * Bytes(p.wm.loaders) + 52) + Bytes(p.wm.loaders) * partition::kBlockHeaderBytes +
         (Bytes(64) << 20);
}

// The loop's progress callback: a failed job stops the workload, a lost GPU leaves the plan,
// and progress is reported at most every 200 ms.
struct LoopWatch {
  const RenderOptions& opt;
  Platform& p;
  const LocalExecutor& executor;
  RenderWorkload& workload;
  const GpuStore* gpu;
  std::chrono::steady_clock::time_point last = std::chrono::steady_clock::now();
  bool gpu_disabled = false;

  void operator()(Time now, const RunStats&) {
    if (executor.failure()) workload.abort();
    if (gpu && !gpu_disabled && gpu->lost()) disable_gpu();
    if (!opt.progress) return;
    const auto t = std::chrono::steady_clock::now();
    if (t - last < std::chrono::milliseconds(200)) return;
    last = t;
    const double total = double(workload.total_camera_rays());
    const double done = double(workload.camera_rays()) - double(workload.paths_alive());
    opt.progress(total > 0 ? done / total : 1.0, now > 0 ? double(workload.counts().created) / now : 0.0);
  }
  // The device is gone: plan no more work for it (jobs already planned there run on the
  // CPU path inside VulkanAggregate, so nothing is lost).
  void disable_gpu() {
    DeviceGraph& g = p.g;
    for (JobTypeId t = 0; t < JobTypeId(g.job_types.size()); ++t) g.timing.at(p.gpu_dev, t).supported = false;
    if (opt.plan_gpu_only)  // the CPU threads take the GPU's job types back (their own timing)
      for (std::size_t d = 0; d < g.computes.size(); ++d)
        if (g.computes[d].kind == ComputeKind::Cpu) {
          g.timing.at(DeviceId(d), p.ri) = g.timing.at(DeviceId(d), p.ric);
          g.timing.at(DeviceId(d), p.si) = g.timing.at(DeviceId(d), p.sic);
        }
    gpu_disabled = true;
  }
};

// ---- report ------------------------------------------------------------------------------

void report_image(const RenderWorkload& workload, const BlockStore& store, const trace::Film& film,
                  RenderResult& res) {
  res.counts = workload.counts();
  res.camera_rays = workload.camera_rays();
  res.first_wave_camera_rays = workload.first_wave();
  res.jobs = workload.jobs_created();
  res.merges = workload.merges();
  res.store = store.stats();
  res.film_dropped = film.dropped();
  res.rgb = film.resolve(res.spp);
  res.sums = film.sums();
  res.samples.resize(std::size_t(res.width) * std::size_t(res.height));
  for (std::size_t px = 0; px < res.samples.size(); ++px) res.samples[px] = film.samples(static_cast<std::uint32_t>(px));
}

// Finished intervals of one kind (the CPU threads' E-jobs, or the loads), by start: how
// long they overlap a span, summed.
class Intervals {
 public:
  void add(Time start, Time end) {
    all_.emplace_back(start, end);
    longest_ = std::max(longest_, end - start);
  }
  void sort() { std::sort(all_.begin(), all_.end()); }
  Time overlap(Time s, Time e) const {
    Time sum = 0;
    for (auto it = std::lower_bound(all_.begin(), all_.end(), std::pair<Time, Time>(s - longest_, -kNever));
         it != all_.end() && it->first < e; ++it)
      sum += std::max(0.0, std::min(e, it->second) - std::max(s, it->first));
    return sum;
  }

 private:
  std::vector<std::pair<Time, Time>> all_;
  Time longest_ = 0;
};

// Measured activities for `rayline calibrate` (Eq. 1 and Eq. 2 fits).
void report_samples(const Schedule& schedule, const JobPool& pool, const Platform& p, const SceneBlocks& sb,
                    RenderResult& res) {
  const DeviceGraph& g = p.g;
  res.first_exec_start = res.seconds;
  // A load's busy share is the CPU threads' E-jobs' overlap with it; an E-job's load share
  // the loads' overlap with it.
  Intervals cpu_jobs, loads;
  int threads = 0;
  for (std::size_t d = 0; d < g.computes.size(); ++d) threads += g.computes[d].kind == ComputeKind::Cpu;
  for (ActivityId id = 0; id < ActivityId(schedule.activity_count()); ++id) {
    const Activity& a = schedule.activity(id);
    if (a.state != ActivityState::Done || a.cancelled) continue;
    if (a.kind == ActivityKind::Exec && g.computes[std::size_t(a.device)].kind == ComputeKind::Cpu)
      cpu_jobs.add(a.start, a.end);
    else if (a.kind == ActivityKind::Transfer && sb.cell_of.count(a.block) && g.channels[std::size_t(a.channel)].to == p.ram)
      loads.add(a.start, a.end);
  }
  cpu_jobs.sort();
  loads.sort();
  auto load_share = [&](Time s, Time e) { return e <= s ? 0.0 : loads.overlap(s, e) / (e - s); };
  auto busy_share = [&](Time s, Time e) { return e <= s || threads == 0 ? 0.0 : cpu_jobs.overlap(s, e) / ((e - s) * threads); };
  for (ActivityId id = 0; id < ActivityId(schedule.activity_count()); ++id) {
    const Activity& a = schedule.activity(id);
    if (a.state != ActivityState::Done) continue;
    if (a.kind == ActivityKind::Exec) {
      res.first_exec_start = std::min(res.first_exec_start, a.start);
      TimingSample t;
      t.device = a.device;
      const std::string& type_name = g.job_types[std::size_t(pool.job(a.job).type)];
      t.type = type_name == "RayIntersect" || type_name == "RayIntersectCpu" ? 0 : 1;
      for (BlockId blk : pool.job(a.job).inputs) t.inputs.push_back({pool.block(blk).kind, pool.block(blk).bytes});
      t.duration = a.end - a.start;
      res.exec_samples.push_back(std::move(t));
      res.exec_load_share.push_back(load_share(a.start, a.end));
    } else if (g.channels[a.channel].network != kNone) {
      res.lan_samples.emplace_back(a.bytes, a.end - a.start);
    } else if (sb.cell_of.count(a.block) && g.channels[a.channel].to == p.ram) {
      res.load_samples.push_back({a.bytes, a.end - a.start, busy_share(a.start, a.end)});
    } else if (g.channels[a.channel].to == p.gmem) {
      res.pcie_samples.emplace_back(a.bytes, a.end - a.start);
    }
  }
}

// The dispatch latency of every E-job on a CPU thread (RenderResult::dispatch_gaps): its
// start minus the latest of its predecessor's end, its inputs' arrival and its creation.
// The loop's latency samples (RenderResult::loop_samples, calibrate's control_loop) are
// the jobs planned after their thread ran dry, in answer to a finished E-job: from the
// later of that ready time and the E-job's end (RuntimeLoop::triggers; a policy that
// waits for a round's last job, as LoadAnyOnce does, is not the loop's latency), against
// that E-job's duration, as the simulator charges it (SimExecutor::on_done).
void report_dispatch(const Schedule& schedule, const JobPool& pool, const Platform& p,
                     const std::vector<RuntimeLoop::Trigger>& triggers, RenderResult& res) {
  const DeviceGraph& g = p.g;
  for (const RuntimeLoop::Trigger& t : triggers)
    if (t.planned_at >= 0 && (res.first_plan_at < 0 || t.planned_at < res.first_plan_at)) res.first_plan_at = t.planned_at;
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    if (g.computes[d].kind != ComputeKind::Cpu) continue;
    Time prev_end = -1;
    for (ActivityId id : schedule.device_timeline(DeviceId(d)).items) {
      const Activity& a = schedule.activity(id);
      if (a.state != ActivityState::Done || a.cancelled) continue;
      if (prev_end >= 0) {
        const Time ready = std::max({prev_end, a.data_ready, pool.job(a.job).created});
        const Time gap = std::max<Time>(0, a.start - ready);
        res.dispatch_gaps.push_back(gap);
        const auto i = static_cast<std::size_t>(id);
        if (a.planned_start >= prev_end && a.data_ready <= prev_end && i < triggers.size() && triggers[i].end >= 0)
          res.loop_samples.emplace_back(triggers[i].exec_seconds, std::max<Time>(0, a.start - std::max(ready, triggers[i].end)));
        if (i < triggers.size() && triggers[i].planned_at >= 0 && triggers[i].planned_at < prev_end && ready <= prev_end)
          res.pickup_samples.push_back(gap);
      }
      prev_end = a.end;
    }
  }
  // ControlLoop::wake: loads dispatched before a dependency on another thread's activity
  // ended (the E-job whose block they evict), which then were not behind their channel's
  // previous load: from that dependency's end to their start (the loader thread woken).
  for (ActivityId id = 0; id < ActivityId(schedule.activity_count()); ++id) {
    const Activity& a = schedule.activity(id);
    const auto i = static_cast<std::size_t>(id);
    if (a.kind != ActivityKind::Transfer || a.state != ActivityState::Done || a.cancelled || i >= triggers.size() ||
        triggers[i].planned_at < 0 || g.channels[std::size_t(a.channel)].to != p.ram ||
        g.memories[std::size_t(g.channels[std::size_t(a.channel)].from)].kind != MemoryKind::Disk)
      continue;
    Time dep_end = -kNever, prev_end = -kNever;
    for (ActivityId d : a.deps) dep_end = std::max(dep_end, schedule.activity(d).end);
    for (ActivityId d : a.timeline_prev) prev_end = std::max(prev_end, schedule.activity(d).end);
    if (dep_end > triggers[i].planned_at && dep_end >= prev_end) res.wake_samples.push_back(std::max<Time>(0, a.start - dep_end));
  }
}

void report_gpu(const RenderOptions& opt, const GpuStore* gpu, RenderResult& res) {
  if (gpu) {
    res.gpu = gpu->stats();
    if (!gpu->failure().empty())
      res.gpu_status = std::string(gpu->lost() ? "lost: " : "used, with failures: ") + gpu->failure();
  }
  res.gpu_resolve_doubtful = opt.gpu_resolve_doubtful;
}

// The plan driven on this machine: GMB's loop (docs/architecture.md control loop) with the
// LocalExecutor, then what it measured.
void run(const RenderOptions& opt, const Frame& f, const Blocks& b, const RenderWorkloadOptions& wo, Platform& p,
         RenderResult& res) {
  JobPool pool;
  Schedule schedule(p.g, pool);
  const SceneBlocks sb = add_scene_blocks(b, p.g, pool, schedule);
  auto scheduler = make_scheduler(opt.scheduler, opt.horizon, opt.aging, opt.adaptive_aging);
  res.scheduler = opt.scheduler;
  res.scheduler_parameters = scheduler->describe();

  trace::Film film(res.width, res.height);
  const trace::TraceSettings ts = trace_settings(opt, f, b, film, res);
  const trace::PinholeCamera camera(f.sc.default_camera(), res.width, res.height);
  RenderWorkload workload(ts, camera, p.g, p.ram, sb.blocks, wo);
  // BVH builds may use every core: out of core the compute threads mostly wait for them
  // (fetching idle), so the disk->RAM channel's T-jobs get done sooner.
  BlockStore store(b.index, b.dir, b.footprint, static_cast<std::uint32_t>(f.sc.materials.size()), f.quality,
                   opt.build_threads > 0 ? opt.build_threads : f.threads);
  store.set_staging_slots(static_cast<std::size_t>(p.wm.loaders));  // one read-ahead per loader
  std::unique_ptr<GpuStore> gpu_store;
  if (p.gpu_ctx) gpu_store = std::make_unique<GpuStore>(*p.gpu_ctx, store);
  std::unique_ptr<ActivityTasks> tasks;
  std::unique_ptr<LocalExecutor> executor_ptr;
  if (opt.cluster) {  // the other ranks get the frame, then the executor's lanes reach them
    opt.cluster->start({opt.scene, b.dir, res.width, res.height, res.spp, res.max_depth, f.threads,
                        opt.build_threads > 0 ? opt.build_threads : f.threads, int(f.quality), opt.seed,
                        ts.skip_empty, ts.continue_in_cell, b.footprint, p.gpu_ctx ? res.gpu_device : std::string()});
    executor_ptr =
        opt.cluster->executor({p.g, schedule, workload, ts, sb.cell_of, store, opt.read_ahead, gpu_store.get()});
  } else {
    const AggregateSources sources{store, gpu_store.get(), opt.batching.recorder, opt.gpu_resolve_doubtful};
    tasks = std::make_unique<ActivityTasks>(
        ActivityTasks::Setup{p.g, schedule, workload, ts, sb.cell_of, p.ram, p.gmem, store, gpu_store.get(), opt.read_ahead},
        make_aggregates(p.g, sources));
    executor_ptr = std::make_unique<LocalExecutor>(
        p.g, [t = tasks.get()](ActivityId id, const Activity& a) { return t->task(id, a); },
        [t = tasks.get()](ActivityId id, const Activity& a) { return t->hint(id, a); });
  }
  LocalExecutor& executor = *executor_ptr;
  res.rss_start_bytes = rss_now();
  res.overhead_bound_bytes = overhead_bound(res, wo, b, p);

  RuntimeLoop loop(*scheduler, executor, workload, pool, schedule);
  loop.record_triggers = true;  // the loop's latency samples (report_dispatch)
  loop.on_progress = [watch = LoopWatch{opt, p, executor, workload, gpu_store.get()}, &opt, &loop, &executor,
                      &g = p.g](Time now, const RunStats& st) mutable {
    watch(now, st);
    if (!opt.cluster) return;
    // A lost rank (render/mpi/README.md, "A rank lost"): its node's devices and data leave
    // the plan; its jobs are planned again on the other ranks.
    for (int r : opt.cluster->take_lost()) {
      Fault f;
      f.at = now;
      f.what = "R" + std::to_string(r);
      f.memories = g.nodes.at(std::size_t(r)).memories;
      f.computes = g.nodes.at(std::size_t(r)).computes;
      loop.add_fault(std::move(f));
      executor.wake_at(now);
    }
  };
  for (const std::string& f : opt.faults) {
    Fault fault = parse_fault(f, p.g);
    if (!fault.memories.empty())  // (the renderer's memories hold the only copy of the rays and the image)
      throw InputError("--fail", f, "the renderer can lose compute devices only (" +
                                        std::string(p.g.computes.front().name) + ", ...), not memory devices or nodes");
    loop.add_fault(std::move(fault));
  }
  store.fail_read(opt.fail_read);
  res.run = loop.run();
  res.seconds = executor.now();
  res.peak_rss_bytes = rss_peak();
  if (auto err = executor.failure()) std::rethrow_exception(err);
  if (res.run.stalled) throw std::runtime_error("render stalled: " + unplaced_summary(pool, schedule));
  if (opt.cluster) opt.cluster->finish(res);

  report_image(workload, store, film, res);
  report_samples(schedule, pool, p, sb, res);
  report_dispatch(schedule, pool, p, loop.triggers(), res);
  report_gpu(opt, gpu_store.get(), res);
  res.metrics_json = render_metrics_json(res, schedule, executor.busy_seconds());
  if (opt.keep_schedule_outputs) {
    res.timeline_json = chrome_trace_json(schedule, true);
    res.jobs_csv = jobs_csv(schedule);
  }
}

}  // namespace

RenderResult render(const RenderOptions& opt) {
  RenderResult res;
  Frame frame;
  resolve_frame(opt, frame, res);
  Blocks blocks;
  prepare_blocks(opt, frame, blocks, res);
  RenderWorkloadOptions wo = opt.batching;
  const Bytes ram_capacity = size_paths(opt, blocks, wo, res);
  Platform platform;
  make_platform(opt, blocks, wo, ram_capacity, platform, res);
  // Camera jobs are traced by the CPU aggregate in place: not with a GPU in the plan, a
  // per-ray profile recorder or other ranks.
  wo.camera_jobs = wo.camera_jobs && blocks.index.blocks.size() == 1 && !platform.gpu_ctx && !wo.recorder && !opt.cluster;
  res.min_batch = wo.min_batch;
  res.max_batch = wo.max_batch;
  res.continue_in_cell = wo.continue_in_cell;
  res.camera_jobs = wo.camera_jobs;
  res.block_bytes = blocks.footprint;
  res.workstation = platform.wm;
  res.platform_json = workstation_json(platform.wm, "the platform of a render (" + res.platform + ")");
  run(opt, frame, blocks, wo, platform, res);
  return res;
}

}  // namespace rayline::engine

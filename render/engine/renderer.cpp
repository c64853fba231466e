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


#include "render/engine/gpu_select.hpp"
#include "render/engine/local_executor.hpp"
#include "render/engine/profile_recorder.hpp"
#include "render/engine/render_metrics.hpp"
#include "render/engine/temp_partition.hpp"
#include "render/engine/workstation.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"
#include "render/scene/scene_stream.hpp"
#include "render/trace/camera.hpp"
#include "common/error.hpp"
#include "sched/policy/scheduler_factory.hpp"
#include "sched/io/trace_output.hpp"
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

}  // namespace

RenderResult render(const RenderOptions& opt) {
  RenderResult res;
  const scene::Scene sc = opt.scene.empty() ? scene::default_scene() : scene::load_scene(opt.scene);
  res.scene_name = opt.scene.empty() ? "<built-in>" : opt.scene;
  const scene::Camera& cam = sc.default_camera();
  res.width = opt.width > 0 ? opt.width : cam.width;
  res.height = opt.height > 0 ? opt.height : cam.height;
  res.spp = opt.spp > 0 ? opt.spp : sc.render.spp;
  res.max_depth = opt.max_depth > 0 ? opt.max_depth : sc.render.max_depth;
  res.seed = opt.seed;
  res.memory_budget = opt.memory_budget;
  if (res.width <= 0 || res.height <= 0 || std::uint64_t(res.width) * std::uint64_t(res.height) > (1ull << 28))
    throw InputError("--resolution", "", "must be positive and at most 2^28 pixels");
  if (std::uint64_t(res.width) * std::uint64_t(res.height) * std::uint64_t(res.spp) >= (1ull << 32))
    throw InputError("--spp", "", "width x height x spp must stay below 2^32 samples");
  trace::BvhQuality quality = opt.memory_budget > 0 ? trace::BvhQuality::Low : trace::BvhQuality::Medium;
  if (opt.bvh_quality == "low") quality = trace::BvhQuality::Low;
  else if (opt.bvh_quality == "medium") quality = trace::BvhQuality::Medium;
  else if (opt.bvh_quality == "high") quality = trace::BvhQuality::High;
  else if (opt.bvh_quality != "auto" && !opt.bvh_quality.empty())
    throw InputError("--bvh-quality", "", "unknown quality '" + opt.bvh_quality + "' (auto, low, medium, high)");
  res.bvh_quality = quality == trace::BvhQuality::Low ? "low" : (quality == trace::BvhQuality::High ? "high" : "medium");
  const int threads = opt.threads > 0 ? opt.threads : std::max(1, int(std::thread::hardware_concurrency()));
  res.threads = threads;

  // ---- blocks on disk ----------------------------------------------------------------
  std::optional<TempPartition> tmp;
  std::string dir = opt.blocks_dir;
  if (dir.empty()) dir = tmp.emplace().path();
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
    // An existing partition is used as it is; a different block count is a mistake.
    const auto idx = partition::load_block_index(dir);
    if (idx.blocks.size() != opt.blocks)
      throw InputError(dir + "/blocks.json", "blocks",
                       "holds " + std::to_string(idx.blocks.size()) + " blocks but --blocks " +
                           std::to_string(opt.blocks) + " was asked for");
  }
  const partition::BlockIndex index = partition::load_block_index(dir);
  const auto nb = static_cast<std::uint32_t>(index.blocks.size());
  res.blocks = nb;
  if (opt.batching.recorder) {  // per-cell statistics of this render
    try {
      opt.batching.recorder->begin(index, res.width, res.height, res.spp, res.max_depth);
    } catch (const std::invalid_argument& e) {
      throw InputError("--record-tiles", "", e.what());
    }
  }
  std::vector<std::uint64_t> footprint(nb);
  Bytes largest = 0, largest_triangles = 0;
  for (std::uint32_t b = 0; b < nb; ++b) {
    // Missing or truncated block files are found before anything runs.
    const auto h = partition::read_block_header((fs::path(dir) / index.blocks[b].file).string());
    footprint[b] = BlockStore::footprint_of(h.triangle_count, quality);
    largest = std::max<Bytes>(largest, footprint[b]);
    largest_triangles = std::max<Bytes>(largest_triangles, h.triangle_count);
    res.scene_block_bytes += footprint[b];
  }
  // ---- the platform: this machine ------------------------------------------------------
  // The budget holds scene blocks and the ray queues of queued jobs alike (both are data
  // in RAM the plan accounts for). Rays are bounded by the paths alive at once: a path
  // holds one path ray and at most one shadow ray per hit. The path cap is lowered so that
  // the largest block plus every ray always fit: the plan can never deadlock on memory.
  const Bytes per_path = Bytes(1 + res.max_depth) * sizeof(trace::RayRecord);
  RenderWorkloadOptions wo = opt.batching;
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
    const Bytes need = largest + 64 * per_path;
    if (opt.memory_budget < need)
      throw InputError("--memory-budget", "",
                       "budget of " + std::to_string(opt.memory_budget) + " bytes is smaller than the largest block (" +
                           std::to_string(largest) + " bytes in RAM) plus room for 64 paths of rays (" +
                           std::to_string(need) + " bytes in all); use more blocks or a larger budget");
    const Bytes fit = (opt.memory_budget - largest) / per_path;
    wo.path_cap = static_cast<std::uint32_t>(
        auto_cap ? std::min<Bytes>({fit, frame_paths, Bytes(1) << 26}) : std::min<Bytes>(wo.path_cap, fit));
    ram_capacity = opt.memory_budget;
  } else {
    ram_capacity = res.scene_block_bytes + Bytes(wo.path_cap) * per_path;
  }
  res.path_cap = wo.path_cap;
  // A profile recorder classifies rays in the CPU kernels: no GPU then.
  std::unique_ptr<gpu::GpuContext> gpu_ctx = opt.batching.recorder ? nullptr : open_gpu(opt, res);
  WorkstationModel wm = workstation_model(opt.platform);
  wm.threads = threads;
  wm.ram_capacity = ram_capacity;
  if (opt.loaders > 0) wm.loaders = opt.loaders;
  res.loaders = wm.loaders;
  // No GPU: none in the plan. A GPU: the platform file's calibrated timing for it is kept
  // (set_gpu seeds the defaults only where the file has none).
  if (!gpu_ctx) {
    set_gpu(wm, 0);
  } else {
    const Bytes budget = gpu_memory_budget(gpu_ctx->info(), opt.gpu_memory_budget);
    // The largest block and one full ray queue must fit, or a GPU job could never be placed.
    const Bytes need = largest + Bytes(wo.max_batch) * sizeof(trace::RayRecord);
    if (budget < need)
      throw InputError("--gpu-memory-budget", "",
                       "budget of " + std::to_string(budget) + " bytes is smaller than the largest block plus one ray queue (" +
                           std::to_string(need) + " bytes); use more blocks or a larger budget");
    set_gpu(wm, budget);
    res.gpu_memory_budget = budget;
  }
  DeviceGraph g = make_workstation(wm, opt.platform);
  res.platform = opt.platform.empty() ? "auto" : opt.platform;
  MemId disk = kNone, ram = kNone, gmem = kNone;
  for (std::size_t i = 0; i < g.memories.size(); ++i) {
    if (g.memories[i].kind == MemoryKind::Disk && disk == kNone) disk = MemId(i);
    if (g.memories[i].kind == MemoryKind::Host && ram == kNone) ram = MemId(i);
    if (g.memories[i].kind == MemoryKind::Gpu && gmem == kNone) gmem = MemId(i);
  }
  DeviceId gpu_dev = kNone;
  JobTypeId ri = kNone, si = kNone, ric = kNone, sic = kNone;  // the GPU's job types, the CPU-only ones
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    if (g.computes[d].kind == ComputeKind::Gpu) gpu_dev = DeviceId(d);
  res.gpu_device_id = gpu_dev == kNone ? -1 : int(gpu_dev);
  if (gpu_dev != kNone) {
    // Rays a GPU kernel cannot decide exactly as Embree would come back flagged
    // kRayCpuOnly (render/gpu/README.md, "Doubtful rays") and are queued as these job types,
    // which only the CPU devices support, with the CPU's Eq. 2 coefficients: GMB plans them
    // (and the RAM copy of their block) like any CPU job, so no sample is lost and nothing
    // unplanned is loaded.
    ri = g.job_type("RayIntersect"), si = g.job_type("ShadowIntersect");
    ric = g.add_job_type("RayIntersectCpu"), sic = g.add_job_type("ShadowIntersectCpu");
    for (std::size_t d = 0; d < g.computes.size(); ++d)
      if (g.computes[d].kind == ComputeKind::Cpu) {
        g.timing.at(DeviceId(d), ric) = g.timing.at(DeviceId(d), ri);
        g.timing.at(DeviceId(d), sic) = g.timing.at(DeviceId(d), si);
        if (opt.plan_gpu_only) g.timing.at(DeviceId(d), ri).supported = g.timing.at(DeviceId(d), si).supported = false;
      }
  }

  // ---- the run -------------------------------------------------------------------------
  JobPool pool;
  Schedule schedule(g, pool);
  std::vector<BlockId> scene_blocks(nb);
  std::map<BlockId, std::uint32_t> cell_of;
  for (std::uint32_t b = 0; b < nb; ++b) {
    DataBlock d;
    d.name = "scene" + std::to_string(b);
    d.kind = DataKind::SceneData;
    d.bytes = footprint[b];
    scene_blocks[b] = pool.add_block(d);
    cell_of[scene_blocks[b]] = b;
    schedule.put_initial(scene_blocks[b], disk, 0, true);
  }
  auto scheduler = make_scheduler(opt.scheduler, opt.horizon, opt.aging, opt.adaptive_aging);
  res.scheduler = opt.scheduler;
  res.scheduler_parameters = scheduler->describe();

  trace::Film film(res.width, res.height);
  trace::TraceSettings ts;
  ts.scene = &sc;
  ts.cells = &index;
  ts.set_bounds(index.bounds);
  ts.film = &film;
  ts.seed = opt.seed;
  ts.max_depth = res.max_depth;
  ts.skip_empty = opt.skip_empty;
  const trace::PinholeCamera camera(cam, res.width, res.height);
  RenderWorkload workload(ts, camera, g, ram, scene_blocks, wo);
  // BVH builds may use every core: out of core the compute threads mostly wait for them
  // (fetching idle), so the disk->RAM channel's T-jobs get done sooner.
  BlockStore store(index, dir, footprint, static_cast<std::uint32_t>(sc.materials.size()), quality,
                   opt.build_threads > 0 ? opt.build_threads : threads);

  store.set_staging_slots(static_cast<std::size_t>(wm.loaders));  // one read-ahead per loader
  std::unique_ptr<GpuStore> gpu_store;
  if (gpu_ctx) gpu_store = std::make_unique<GpuStore>(*gpu_ctx, store);
  if (gpu_store) gpu_store->set_resolve_doubtful(opt.gpu_resolve_doubtful);

  // Evictions the plan decided, by the activity that needed the space (Schedule::Eviction):
  // scene blocks leave RAM or GPU memory, ray queues leave GPU memory.
  struct Victims {
    std::vector<std::uint32_t> ram_cells, gpu_cells;
    std::vector<BlockId> gpu_queues;
  };
  std::size_t ev_cursor = 0;
  std::map<ActivityId, Victims> victims;
  std::map<BlockId, std::pair<RayJob*, std::pair<std::size_t, std::uint32_t>>> queue_rays;  // RAM->GPU uploads
  auto task_for = [&](ActivityId id, const Activity& a) -> LocalExecutor::Task {
    const auto& evs = schedule.evictions();
    for (; ev_cursor < evs.size(); ++ev_cursor) {
      const Eviction& e = evs[ev_cursor];
      auto it = cell_of.find(e.block);
      if (e.mem == ram && it != cell_of.end()) victims[e.for_activity].ram_cells.push_back(it->second);
      if (e.mem == gmem && it != cell_of.end()) victims[e.for_activity].gpu_cells.push_back(it->second);
      if (e.mem == gmem && it == cell_of.end()) victims[e.for_activity].gpu_queues.push_back(e.block);
    }
    Victims evict;
    if (auto v = victims.find(id); v != victims.end()) {
      evict = std::move(v->second);
      victims.erase(v);
    }
    GpuStore* gs = gpu_store.get();
    auto do_evict = [&store, gs](const Victims& v) {
      for (std::uint32_t c : v.ram_cells) store.evict(c);
      if (!gs) return;
      for (std::uint32_t c : v.gpu_cells) gs->evict(c);
      for (BlockId q : v.gpu_queues) gs->drop_rays(q);
    };
    if (a.kind == ActivityKind::Exec) {
      RayJob* job = &workload.job(a.job);
      if (gs && a.device == gpu_dev) {
        // The job's queues will be uploaded by T-jobs dispatched later; record where their rays are.
        return [&ts, gs, job, evict = std::move(evict), do_evict] {
          do_evict(evict);
          gs->run_job(ts, job->cell, job->kind, job->rays, job->parts, job->out, job->counts);
          std::vector<trace::RayRecord>().swap(job->rays);
        };
      }
      return [&ts, &store, job, rec = opt.batching.recorder, evict = std::move(evict), do_evict] {
        do_evict(evict);
        const auto geo = store.get(job->cell);
        if (rec) rec->trace_job(ts, *geo, *job);  // the same kernels, ray by ray
        else trace::intersect(ts, *geo, job->kind, job->rays, job->out, job->counts);
        std::vector<trace::RayRecord>().swap(job->rays);
      };
    }
    auto it = cell_of.find(a.block);
    const MemId to = g.channels[a.channel].to;
    const bool scene_block = it != cell_of.end();
    const std::uint32_t cell = scene_block ? it->second : 0;
    if (gs && to == gmem) {
      if (scene_block)
        return [gs, cell, evict = std::move(evict), do_evict] {
          do_evict(evict);
          gs->load(cell);
        };
      // A ray queue RAM->GPU: the rays of that queue inside the job that consumes it.
      std::span<const trace::RayRecord> rays;
      if (const JobId j = workload.consumer(a.block); j != kNone) {
        RayJob& rj = workload.job(j);
        std::size_t off = 0;
        for (const auto& [q, n] : rj.parts) {
          if (q == a.block) rays = std::span<const trace::RayRecord>(rj.rays).subspan(off, n);
          off += n;
        }
      }
      return [&ts, gs, q = a.block, rays, evict = std::move(evict), do_evict] {
        do_evict(evict);
        if (!rays.empty()) gs->load_rays(q, rays, ts);
      };
    }
    // Disk -> RAM loads a block; ray queues live in host memory shared by every CPU device.
    const bool load = scene_block && to == ram;
    return [&store, load, cell, evict = std::move(evict), do_evict] {
      do_evict(evict);
      if (load) store.load(cell);
    };
  };
  res.rss_start_bytes = rss_now();
  // What the run may add beyond the budget (README, "Memory"): the film, ray records in
  // flight twice over (staged and in jobs), and a fixed allowance for thread stacks,
  // Embree's and the allocator's own state.
  // Loading adds, outside the budget, one staged block file (read-ahead) per loader and one
  // block's idle recycled arrays (ArrayPool): 40 per loader + 52 bytes per triangle of the
  // largest block.
  res.overhead_bound_bytes = Bytes(res.width) * Bytes(res.height) * 28 + 2 * Bytes(wo.path_cap) * per_path +
                             largest_triangles * (40 * Bytes(wm.loaders) + 52) +
                             Bytes(wm.loaders) * partition::kBlockHeaderBytes + (Bytes(64) << 20);
  // Read-ahead (LocalExecutor's hints): the next disk->RAM load reads its block file while
  // the channel still builds the previous block's BVH or waits for its dependencies.
  auto hint_for = [&](ActivityId, const Activity& a) -> LocalExecutor::Task {
    if (a.kind != ActivityKind::Transfer || g.channels[a.channel].to != ram || !opt.read_ahead) return {};
    const auto it = cell_of.find(a.block);
    if (it == cell_of.end()) return {};
    return [&store, cell = it->second] { store.read_ahead(cell); };
  };
  LocalExecutor executor(g, task_for, hint_for);
  RuntimeLoop loop(*scheduler, executor, workload, pool, schedule);
  auto last = std::chrono::steady_clock::now();
  bool gpu_disabled = false;
  loop.on_progress = [&](Time now, const RunStats&) {
    if (executor.failure()) workload.abort();
    if (gpu_store && !gpu_disabled && gpu_store->lost()) {
      // The device is gone: plan no more work for it (jobs already planned there run on
      // the CPU path inside GpuStore::run_job, so nothing is lost).
      for (JobTypeId t = 0; t < JobTypeId(g.job_types.size()); ++t) g.timing.at(gpu_dev, t).supported = false;
      if (opt.plan_gpu_only)  // the CPU threads take the GPU's job types back (their own timing)
        for (std::size_t d = 0; d < g.computes.size(); ++d)
          if (g.computes[d].kind == ComputeKind::Cpu) {
            g.timing.at(DeviceId(d), ri) = g.timing.at(DeviceId(d), ric);
            g.timing.at(DeviceId(d), si) = g.timing.at(DeviceId(d), sic);
          }
      gpu_disabled = true;
    }
    if (!opt.progress) return;
    const auto t = std::chrono::steady_clock::now();
    if (t - last < std::chrono::milliseconds(200)) return;
    last = t;
    const double total = double(workload.total_camera_rays());
    const double done = double(workload.camera_rays()) - double(workload.paths_alive());
    opt.progress(total > 0 ? done / total : 1.0, now > 0 ? double(workload.counts().created) / now : 0.0);
  };
  res.run = loop.run();
  res.seconds = executor.now();
  res.peak_rss_bytes = rss_peak();
  if (auto err = executor.failure()) std::rethrow_exception(err);
  if (res.run.stalled) throw std::runtime_error("render stalled: " + unplaced_summary(pool, schedule));

  res.counts = workload.counts();
  res.camera_rays = workload.camera_rays();
  res.jobs = workload.jobs_created();
  res.merges = workload.merges();
  res.store = store.stats();
  res.film_dropped = film.dropped();
  res.rgb = film.resolve(res.spp);
  res.sums = film.sums();
  res.samples.resize(std::size_t(res.width) * std::size_t(res.height));
  for (std::size_t p = 0; p < res.samples.size(); ++p) res.samples[p] = film.samples(static_cast<std::uint32_t>(p));
  res.first_exec_start = res.seconds;
  for (ActivityId id = 0; id < ActivityId(schedule.activity_count()); ++id) {
    const Activity& a = schedule.activity(id);
    if (a.state != ActivityState::Done) continue;
    if (a.kind == ActivityKind::Exec) {
      res.first_exec_start = std::min(res.first_exec_start, a.start);
      TimingSample t;
      t.device = a.device;
      const std::string& type_name = g.job_types[std::size_t(pool.job(a.job).type)];
      t.type = type_name == "RayIntersect" || type_name == "RayIntersectCpu" ? 0 : 1;
      for (BlockId b : pool.job(a.job).inputs) t.inputs.push_back({pool.block(b).kind, pool.block(b).bytes});
      t.duration = a.end - a.start;
      res.exec_samples.push_back(std::move(t));
    } else if (cell_of.count(a.block) && g.channels[a.channel].to == ram) {
      res.load_samples.emplace_back(a.bytes, a.end - a.start);
    } else if (g.channels[a.channel].to == gmem) {
      res.pcie_samples.emplace_back(a.bytes, a.end - a.start);
    }
  }
  if (gpu_store) {
    res.gpu = gpu_store->stats();
    if (!gpu_store->failure().empty())
      res.gpu_status = std::string(gpu_store->lost() ? "lost: " : "used, with failures: ") + gpu_store->failure();
  }
  res.gpu_resolve_doubtful = opt.gpu_resolve_doubtful;
  res.metrics_json = render_metrics_json(res, schedule, executor.busy_seconds());
  if (opt.keep_schedule_outputs) {
    res.timeline_json = chrome_trace_json(schedule, true);
    res.jobs_csv = jobs_csv(schedule);
  }
  return res;
}

}  // namespace rayline::engine

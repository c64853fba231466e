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
#include <thread>

#include "render/engine/local_executor.hpp"
#include "render/engine/render_metrics.hpp"
#include "render/engine/workstation.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"
#include "render/scene/scene_stream.hpp"
#include "render/trace/camera.hpp"
#include "sched/error.hpp"
#include "sched/scheduler_factory.hpp"
#include "sched/trace_output.hpp"

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

// A temporary partition folder, removed when the render ends.
struct TempDir {
  fs::path path;
  ~TempDir() {
    std::error_code ec;
    if (!path.empty()) fs::remove_all(path, ec);
  }
};

std::uint32_t auto_blocks(std::uint64_t triangles, Bytes budget) {
  const double fp = double(BlockStore::footprint_of(triangles, trace::BvhQuality::Low));
  if (budget == 0) return std::uint32_t(std::clamp<double>(std::ceil(double(triangles) / 4e6), 1, 64));
  // At least four blocks resident at once, and a few cells to balance the threads.
  return std::uint32_t(std::clamp<double>(std::ceil(4 * fp / double(budget)), 8, 1024));
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
    throw InputError("--resolution", "resolution", "must be positive and at most 2^28 pixels");
  if (std::uint64_t(res.width) * std::uint64_t(res.height) * std::uint64_t(res.spp) >= (1ull << 32))
    throw InputError("--spp", "spp", "width x height x spp must stay below 2^32 samples");
  trace::BvhQuality quality = opt.memory_budget > 0 ? trace::BvhQuality::Low : trace::BvhQuality::Medium;
  if (opt.bvh_quality == "low") quality = trace::BvhQuality::Low;
  else if (opt.bvh_quality == "medium") quality = trace::BvhQuality::Medium;
  else if (opt.bvh_quality == "high") quality = trace::BvhQuality::High;
  else if (opt.bvh_quality != "auto" && !opt.bvh_quality.empty())
    throw InputError("--bvh-quality", "bvh-quality", "unknown quality '" + opt.bvh_quality + "' (auto, low, medium, high)");
  res.bvh_quality = quality == trace::BvhQuality::Low ? "low" : (quality == trace::BvhQuality::High ? "high" : "medium");
  const int threads = opt.threads > 0 ? opt.threads : std::max(1, int(std::thread::hardware_concurrency()));
  res.threads = threads;

  // ---- blocks on disk ----------------------------------------------------------------
  TempDir tmp;
  std::string dir = opt.blocks_dir;
  if (dir.empty()) {
    tmp.path = fs::temp_directory_path() / ("rayline-blocks-" + std::to_string(::getpid()) + "-" +
                                            std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
    dir = tmp.path.string();
  }
  if (!fs::exists(fs::path(dir) / "blocks.json")) {
    const auto t0 = std::chrono::steady_clock::now();
    partition::PartitionOptions po;
    po.blocks = opt.blocks > 0 ? opt.blocks : auto_blocks(scene::scene_stats(sc).triangles, opt.memory_budget);
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
  std::vector<std::uint64_t> footprint(nb);
  Bytes largest = 0;
  for (std::uint32_t b = 0; b < nb; ++b) {
    // Missing or truncated block files are found before anything runs.
    const auto h = partition::read_block_header((fs::path(dir) / index.blocks[b].file).string());
    footprint[b] = BlockStore::footprint_of(h.triangle_count, quality);
    largest = std::max<Bytes>(largest, footprint[b]);
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
  Bytes ram_capacity = 0;
  if (opt.memory_budget > 0) {
    const Bytes need = largest + 64 * per_path;
    if (opt.memory_budget < need)
      throw InputError("--memory-budget", "memory-budget",
                       "budget of " + std::to_string(opt.memory_budget) + " bytes is smaller than the largest block (" +
                           std::to_string(largest) + " bytes in RAM) plus room for 64 paths of rays (" +
                           std::to_string(need) + " bytes in all); use more blocks or a larger budget");
    wo.path_cap = static_cast<std::uint32_t>(std::min<Bytes>(wo.path_cap, (opt.memory_budget - largest) / per_path));
    ram_capacity = opt.memory_budget;
  } else {
    ram_capacity = res.scene_block_bytes + Bytes(wo.path_cap) * per_path;
  }
  res.path_cap = wo.path_cap;
  DeviceGraph g;
  if (opt.platform.empty() || opt.platform == "auto") {
    WorkstationModel m;
    m.threads = threads;
    m.ram_capacity = ram_capacity;
    g = make_workstation(m);
  } else {
    g = load_workstation(opt.platform, threads, ram_capacity);
  }
  res.platform = opt.platform.empty() ? "auto" : opt.platform;
  MemId disk = kNone, ram = kNone;
  for (std::size_t i = 0; i < g.memories.size(); ++i) {
    if (g.memories[i].kind == MemoryKind::Disk && disk == kNone) disk = MemId(i);
    if (g.memories[i].kind == MemoryKind::Host && ram == kNone) ram = MemId(i);
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
  auto scheduler = make_scheduler(opt.scheduler, opt.horizon);
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
  const trace::PinholeCamera camera(cam, res.width, res.height);
  RenderWorkload workload(ts, camera, g, ram, scene_blocks, wo);
  // BVH builds may use every core: out of core the compute threads mostly wait for them
  // (fetching idle), so the disk->RAM channel's T-jobs get done sooner.
  BlockStore store(index, dir, footprint, static_cast<std::uint32_t>(sc.materials.size()), quality,
                   opt.build_threads > 0 ? opt.build_threads : threads);

  // Evictions the plan decided, by the activity that needed the space (Schedule::Eviction).
  std::size_t ev_cursor = 0;
  std::map<ActivityId, std::vector<std::uint32_t>> victims;
  auto task_for = [&](ActivityId id, const Activity& a) -> LocalExecutor::Task {
    const auto& evs = schedule.evictions();
    for (; ev_cursor < evs.size(); ++ev_cursor) {
      const Eviction& e = evs[ev_cursor];
      auto it = cell_of.find(e.block);
      if (e.mem == ram && it != cell_of.end()) victims[e.for_activity].push_back(it->second);
    }
    std::vector<std::uint32_t> evict;
    if (auto v = victims.find(id); v != victims.end()) {
      evict = std::move(v->second);
      victims.erase(v);
    }
    if (a.kind == ActivityKind::Exec) {
      RayJob* job = &workload.job(a.job);
      return [&ts, &store, job, evict = std::move(evict)] {
        for (std::uint32_t c : evict) store.evict(c);
        const auto geo = store.get(job->cell);
        if (job->kind == trace::RayKind::Path) trace::ray_intersect(ts, *geo, job->rays, job->out, job->counts);
        else trace::shadow_intersect(ts, *geo, job->rays, job->out, job->counts);
        std::vector<trace::RayRecord>().swap(job->rays);
      };
    }
    auto it = cell_of.find(a.block);
    const bool load = it != cell_of.end() && g.channels[a.channel].to == ram;
    const std::uint32_t cell = load ? it->second : 0;
    // Ray queues live in host memory shared by every compute device here: nothing moves.
    return [&store, load, cell, evict = std::move(evict)] {
      for (std::uint32_t c : evict) store.evict(c);
      if (load) store.load(cell);
    };
  };
  res.rss_start_bytes = rss_now();
  // What the run may add beyond the budget (README, "Memory"): the film, ray records in
  // flight twice over (staged and in jobs), and a fixed allowance for thread stacks,
  // Embree's and the allocator's own state.
  res.overhead_bound_bytes = Bytes(res.width) * Bytes(res.height) * 28 + 2 * Bytes(wo.path_cap) * per_path +
                             (Bytes(64) << 20);
  LocalExecutor executor(g, task_for);
  RuntimeLoop loop(*scheduler, executor, workload, pool, schedule);
  auto last = std::chrono::steady_clock::now();
  loop.on_progress = [&](Time now, const RunStats&) {
    if (executor.failure()) workload.abort();
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
  if (res.run.stalled) throw std::runtime_error("render stalled: queued jobs no device can run (plan bug)");

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
      t.type = pool.job(a.job).type == g.job_type("RayIntersect") ? 0 : 1;
      for (BlockId b : pool.job(a.job).inputs) t.inputs.push_back({pool.block(b).kind, pool.block(b).bytes});
      t.duration = a.end - a.start;
      res.exec_samples.push_back(std::move(t));
    } else if (cell_of.count(a.block) && g.channels[a.channel].to == ram) {
      res.load_samples.emplace_back(a.bytes, a.end - a.start);
    }
  }
  res.metrics_json = render_metrics_json(res, schedule, executor.busy_seconds());
  if (opt.keep_schedule_outputs) {
    res.timeline_json = chrome_trace_json(schedule, true);
    res.jobs_csv = jobs_csv(schedule);
  }
  return res;
}

}  // namespace rayline::engine

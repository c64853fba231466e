#include "render/engine/activity_tasks.hpp"

#include <algorithm>
#include <span>
#include <utility>

#include "common/error.hpp"
#include "render/engine/ray_log_recorder.hpp"

namespace rayline::engine {

ActivityTasks::ActivityTasks(Setup s, std::vector<std::unique_ptr<accel::Aggregate>> aggregates)
    : s_(s), aggregates_(std::move(aggregates)) {}

ActivityTasks::Victims ActivityTasks::victims_of(ActivityId id) {
  const auto& evs = s_.schedule.evictions();
  for (; ev_cursor_ < evs.size(); ++ev_cursor_) {
    const Eviction& e = evs[ev_cursor_];
    const auto it = s_.cell_of.find(e.block);
    const bool scene_block = it != s_.cell_of.end();
    if (e.mem == s_.ram && scene_block) victims_[e.for_activity].ram_cells.push_back(it->second);
    if (e.mem == s_.gmem && scene_block) victims_[e.for_activity].gpu_cells.push_back(it->second);
    if (e.mem == s_.gmem && !scene_block) victims_[e.for_activity].gpu_queues.push_back(e.block);
  }
  Victims v;
  if (auto it = victims_.find(id); it != victims_.end()) {
    v = std::move(it->second);
    victims_.erase(it);
  }
  return v;
}

void ActivityTasks::evict(const Victims& v) const {
  for (std::uint32_t c : v.ram_cells) s_.store.evict(c);
  if (!s_.gpu) return;
  for (std::uint32_t c : v.gpu_cells) s_.gpu->evict(c);
  for (BlockId q : v.gpu_queues) s_.gpu->drop_rays(q);
}

LocalExecutor::Task ActivityTasks::task(ActivityId id, const Activity& a) {
  Victims v = victims_of(id);
  if (a.kind == ActivityKind::Exec) return exec_task(a, std::move(v));
  const MemId to = s_.g.channels[a.channel].to;
  if (s_.gpu && to == s_.gmem) return gpu_transfer_task(a, std::move(v));
  // Disk -> RAM loads a block; ray queues live in host memory shared by every CPU device.
  const auto it = s_.cell_of.find(a.block);
  const bool load = it != s_.cell_of.end() && to == s_.ram;
  const std::uint32_t cell = load ? it->second : 0;
  return [this, load, cell, v = std::move(v)] {
    evict(v);
    if (!load) return;
    try {
      s_.store.load(cell);
    } catch (const InputError& e) {
      // A read error or a damaged block file (docs/faults.md): the runtime plans the load
      // again, and after its retries ends the run with this error (exit 2, the file named).
      throw ActivityError(e.what(), std::current_exception());
    }
  };
}

LocalExecutor::Task ActivityTasks::exec_task(const Activity& a, Victims v) {
  RayJob* job = &s_.workload.job(a.job);
  accel::Aggregate* aggregate = aggregates_.at(std::size_t(a.device)).get();
  const RayLogRecorder* log = s_.workload.ray_log();
  return [this, job, aggregate, log, v = std::move(v)] {
    evict(v);
    const auto kind = static_cast<trace::RayKind>(job->slot % 2);
    accel::Aggregate::PassObserver observe;
    if (log)  // each pass as the ray log sees it: the identities of its inputs, the rays it made
      observe = [job, log](trace::RayKind, std::span<const trace::RayRecord> in, std::span<const trace::RayRecord> out) {
        auto& pass = job->log_passes.emplace_back();
        pass.first.reserve(in.size());
        for (const trace::RayRecord& r : in) pass.first.push_back(log->id(r));
        pass.second.assign(out.begin(), out.end());
      };
    if (job->camera_count == 0) {
      aggregate->intersect(s_.ts, accel::QueueJob{job->cell, kind, job->rays, job->parts}, job->out, job->counts, observe);
      std::vector<trace::RayRecord>().swap(job->rays);
      return;
    }
    // A camera job (one cell): its camera rays made here and traced, a chunk at a time so
    // that a chunk's rays and the rays they make stay in this core's caches. Every ray of
    // the job belongs to one of its camera rays' pixels, a few rows of tiles, so the film is
    // a window over those rows, summed without atomics and added once at the end (the same
    // sums, film.hpp).
    const auto [pixel0, pixels] = s_.workload.camera_order().pixel_span(job->camera_first, job->camera_count);
    trace::Film window = trace::Film::window(*s_.ts.film, pixel0, pixels);
    trace::TraceSettings ts = s_.ts;
    ts.film = &window;
    constexpr std::uint64_t kChunk = 2048;
    std::vector<trace::RayRecord> rays;
    rays.reserve(kChunk);
    for (std::uint64_t first = job->camera_first, end = first + job->camera_count; first < end; first += kChunk) {
      rays.clear();
      s_.workload.camera_job_rays(ts, first, std::min(kChunk, end - first), rays, job->counts);
      if (observe) observe(trace::RayKind::Path, {}, rays);
      aggregate->intersect(ts, accel::QueueJob{job->cell, trace::RayKind::Path, rays, {}}, job->out, job->counts, observe);
    }
    s_.ts.film->merge(window);
  };
}

LocalExecutor::Task ActivityTasks::gpu_transfer_task(const Activity& a, Victims v) {
  GpuStore* gpu = s_.gpu;
  if (const auto it = s_.cell_of.find(a.block); it != s_.cell_of.end())
    return [this, gpu, cell = it->second, v = std::move(v)] {
      evict(v);
      gpu->load(cell);
    };
  // A ray queue RAM->GPU: the rays of that queue inside the job that consumes it.
  const std::span<const trace::RayRecord> rays = s_.workload.queue_rays(a.block);
  return [this, gpu, q = a.block, rays, v = std::move(v)] {
    evict(v);
    if (!rays.empty()) gpu->load_rays(q, rays, s_.ts);
  };
}

LocalExecutor::Task ActivityTasks::hint(ActivityId, const Activity& a) const {
  if (a.kind != ActivityKind::Transfer || s_.g.channels[a.channel].to != s_.ram || !s_.read_ahead) return {};
  const auto it = s_.cell_of.find(a.block);
  if (it == s_.cell_of.end()) return {};
  BlockStore* store = &s_.store;
  return [store, cell = it->second] { store->read_ahead(cell); };
}

}  // namespace rayline::engine

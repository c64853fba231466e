// The renderer's ray-batching policy as a Workload (docs/architecture.md control loop;
// Fig. 3, Sec. 3.1, 5.1), written once for both engines: `rayline render` drives it with
// real ray records traced by Embree or Vulkan (render/engine/render_workload.hpp), and
// `rayline simulate --like` with the records of a ray log, whose outcomes were recorded
// from a render (workload/render_twin.hpp, docs/validation.md). Only the ray-outcome oracle
// differs; every rule below is shared:
//   * camera rays are generated in waves, at most `path_cap` paths alive (ray memory); with
//     `camera_jobs` (one cell), by the E-jobs that trace them (Fig. 3's GenerateRays fused
//     into the first RayIntersect): a job then carries a range of camera indices, not rays;
//   * every ray waits in the queue of its cell and slot (path / shadow, and the same kinds
//     flagged CPU-only); a queue becomes a RayIntersect / ShadowIntersect E-job on
//     (SceneData_b, RayQueue_b);
//   * a queue of a resident cell (a copy of its block on a memory a compute device works
//     from, in the plan) becomes a job at `min_batch` rays, other cells' at 16 x min_batch
//     (Sec. 5.1: batch rays to amortise data movement), at most `max_batch` per job;
//   * a new queue joins the still-queued job of its cell and slot while that job stays
//     under max_batch (queues merge on arrival, Sec. 5.1);
//   * while fewer jobs are queued than there are compute devices, the largest queues
//     become jobs, resident cells first; a non-resident cell only when nothing is queued.
//
// `Ray` needs a `cell` member; `Traits::slot(ray)` gives its slot in [0, kBatchSlots):
// 0 path, 1 shadow, 2 and 3 the same kinds CPU-only. `Counts` needs `paths_ended` and +=.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "sched/runtime/workload.hpp"

namespace rayline {

inline constexpr int kBatchSlots = 4;
// The timing model and the memory budget charge 64 bytes per queued ray (render/integrator/ray.hpp).
inline constexpr Bytes kRayRecordBytes = 64;
// The ray bytes one path can hold at once: one path ray and at most one shadow ray per hit.
inline Bytes path_bytes(int max_depth) { return Bytes(1 + max_depth) * kRayRecordBytes; }
// Paths whose rays fit in `budget` next to the largest block (the renderer's automatic
// paths-in-flight cap under a budget; its twin's too): at most the frame's and 2^26. The
// caller checks budget >= largest + 64 x path_bytes first.
inline std::uint32_t paths_in_budget(Bytes budget, Bytes largest, int max_depth, Bytes frame_paths) {
  return static_cast<std::uint32_t>(std::min<Bytes>({(budget - largest) / path_bytes(max_depth), frame_paths, Bytes(1) << 26}));
}

struct RayBatchOptions {
  int spp = 4;
  std::uint32_t path_cap = 1u << 17;   // paths alive at once (the renderer: 0 = auto, renderer.cpp)
  std::uint32_t min_batch = 4096;      // rays per job before a resident cell's queue is worth a job
  std::uint32_t max_batch = 1u << 16;  // rays per job at most (load balance)
  // Rays a job makes in its own cell (shadow rays, continuations that start there) are
  // traced in that job by an engine that traces in place (the CPU), instead of waiting in
  // the cell's queue for a job of their own: Fig. 3's loop closed inside the resident block.
  // With one block, a job traces its camera rays' whole paths.
  bool continue_in_cell = true;
  // Camera rays are made by the job that traces them, on the compute device, instead of on
  // the loop's thread and through a queue; only where the scene is one cell (every camera
  // ray that meets the scene enters it), elsewhere ignored. Camera jobs hold a quarter of
  // the paths in flight per compute device, so each device has planned work queued behind
  // the job it runs.
  bool camera_jobs = true;
};

// The rays of one E-job and what it produced (written by whoever traces it, read by the
// loop after the Finished event).
template <class Ray, class Counts>
struct RayBatchJob {
  int slot = 0;
  std::uint32_t cell = 0;
  std::vector<Ray> rays;
  std::uint64_t input = 0;  // rays handed to the job
  // A camera job (RayBatchOptions::camera_jobs): camera rays [camera_first, camera_first +
  // camera_count) of the camera order (workload/camera_order.hpp: tiles, then pixels, then
  // samples), made by whoever traces the job; `rays` is empty.
  std::uint64_t camera_first = 0, camera_count = 0;
  // The job's ray queues (RayQueue/ShadowRayQueue blocks merged into it, Sec. 5.1) and
  // their ray counts, in the order of `rays`: a queue moves RAM->GPU as its own T-job.
  std::vector<std::pair<BlockId, std::uint32_t>> parts;
  std::vector<Ray> out;
  Counts counts;
  // The job's passes as a ray log sees them, in order (the renderer frees the rays
  // themselves on the worker thread): the identities of each pass's input rays and the rays
  // it made. One pass, or more under continue_in_cell.
  std::vector<std::pair<std::vector<std::uint64_t>, std::vector<Ray>>> log_passes;
};

template <class Ray, class Counts, class Traits>
class RayBatchWorkload : public Workload {
 public:
  using Job = RayBatchJob<Ray, Counts>;

  // `scene_blocks[c]` is the SceneData block of cell c (already in the pool, on disk);
  // `ram` the host memory that holds the ray queues. `total_camera_rays` = pixels x spp.
  RayBatchWorkload(const DeviceGraph& g, MemId ram, std::vector<BlockId> scene_blocks, RayBatchOptions opt,
                   std::uint64_t total_camera_rays)
      : g_(g), ram_(ram), scene_blocks_(std::move(scene_blocks)), opt_(opt), staging_(scene_blocks_.size()),
        open_(scene_blocks_.size(), {kNone, kNone, kNone, kNone}), total_camera_(total_camera_rays) {
    opt_.camera_jobs = opt_.camera_jobs && scene_blocks_.size() == 1;
    type_[0] = g.job_type("RayIntersect");
    type_[1] = g.job_type("ShadowIntersect");
    type_[2] = g.job_type("RayIntersectCpu");
    type_[3] = g.job_type("ShadowIntersectCpu");
    if (type_[2] == kNone || type_[3] == kNone) type_[2] = type_[0], type_[3] = type_[1];
    for (std::size_t m = 0; m < g.memories.size(); ++m)
      if (!g.computes_on(MemId(m)).empty()) near_.push_back(MemId(m));
  }

  void start(Time now, JobPool& pool, Schedule& s) override {
    generate(now, pool);
    first_wave_ = opt_.camera_jobs ? 0 : next_camera_;
    flush(now, pool, s, false);
  }
  void on_job_finished(JobId j, Time now, JobPool& pool, Schedule& s) override {
    if (static_cast<std::size_t>(j) >= jobs_.size() || !jobs_[static_cast<std::size_t>(j)]) return;
    std::unique_ptr<Job> done = std::move(jobs_[static_cast<std::size_t>(j)]);
    job_done(*done);
    counts_ += done->counts;
    for (const auto& part : done->parts) consumer_.erase(part.first);
    in_jobs_ -= done->input;
    paths_alive_ -= done->counts.paths_ended;
    stage(done->out);
    done.reset();
    generate(now, pool);
    flush(now, pool, s, false);
  }
  void on_idle(Time now, JobPool& pool, Schedule& s) override {
    generate(now, pool);
    flush(now, pool, s, true);
  }
  bool finished() const override {
    return aborted_ || (next_camera_ == total_camera_ && staged_ == 0 && in_jobs_ == 0);
  }

  // Jobs whose ray queues were lost with a device (a rank of a distributed render): their
  // rays are still here, in the jobs (an engine frees them only once a job ran), so they go
  // back to their queues and become new jobs. Any other lost block ends the run, as for
  // every workload.
  void on_lost(Time now, const std::vector<JobId>& jobs, const std::vector<BlockId>& blocks, JobPool& pool,
               Schedule& s) override {
    for (BlockId b : blocks)
      if (pool.block(b).kind != DataKind::RayQueue && pool.block(b).kind != DataKind::ShadowRayQueue)
        return Workload::on_lost(now, jobs, blocks, pool, s);
    for (JobId j : jobs) {
      if (static_cast<std::size_t>(j) >= jobs_.size() || !jobs_[static_cast<std::size_t>(j)]) continue;
      std::unique_ptr<Job> lost = std::move(jobs_[static_cast<std::size_t>(j)]);
      for (const auto& part : lost->parts) consumer_.erase(part.first);
      for (auto& slots : open_)
        for (JobId& o : slots)
          if (o == j) o = kNone;
      in_jobs_ -= lost->input;
      if (lost->camera_count > 0) make_camera_job(lost->camera_first, lost->camera_count, now, pool, false);
      else stage(lost->rays);
    }
    flush(now, pool, s, false);
  }

  // Stop making work (a job failed): finished() turns true.
  void abort() { aborted_ = true; }
  Job& job(JobId j) { return *jobs_.at(static_cast<std::size_t>(j)); }
  // The job a ray queue block was merged into (kNone for other blocks).
  JobId consumer(BlockId queue) const {
    auto it = consumer_.find(queue);
    return it == consumer_.end() ? kNone : it->second;
  }
  // The rays of ray queue `queue` inside the job that consumes it (empty when no job holds it
  // or the job's rays are gone): what a T-job moving that queue carries.
  std::span<const Ray> queue_rays(BlockId queue) {
    const JobId j = consumer(queue);
    if (j == kNone || static_cast<std::size_t>(j) >= jobs_.size() || !jobs_[static_cast<std::size_t>(j)]) return {};
    const Job& job = *jobs_[static_cast<std::size_t>(j)];
    std::size_t off = 0;
    for (const auto& [q, n] : job.parts) {
      if (q == queue) return off + n <= job.rays.size() ? std::span<const Ray>(job.rays).subspan(off, n) : std::span<const Ray>{};
      off += n;
    }
    return {};
  }
  const Counts& counts() const { return counts_; }
  std::uint64_t camera_rays() const { return next_camera_; }
  std::uint64_t total_camera_rays() const { return total_camera_; }
  std::uint64_t merges() const { return merges_; }
  std::uint64_t jobs_created() const { return jobs_created_; }
  std::uint64_t paths_alive() const { return paths_alive_; }
  // Camera rays the loop made in start(), before its first plan (0 with camera jobs: the
  // jobs make them): the loop's start-up work (ControlLoop::per_camera_ray).
  std::uint64_t first_wave() const { return first_wave_; }
  // The options in force (camera_jobs off where the scene has more than one cell).
  const RayBatchOptions& options() const { return opt_; }

 protected:
  // Staged rays of one (cell, slot): a FIFO whose taken front is skipped by `head` and
  // dropped once it is half the vector (each ray is copied O(1) times, not once per job).
  struct Staged {
    std::vector<Ray> v;
    std::size_t head = 0;
    std::size_t size() const { return v.size() - head; }
    bool empty() const { return v.size() == head; }
    // Room for n more, growing geometrically (a queue grows at most once per staging).
    void reserve_more(std::size_t n) {
      if (v.capacity() < v.size() + n) v.reserve(std::max(v.size() + n, 2 * v.capacity()));
    }
  };

  // The oracle's two halves. `make_camera_rays` appends the camera rays with indices
  // [first, first + n) (pixel = i % pixels, sample = i / pixels) to their queues (through
  // `queue(q)` / stage_one) and returns their counts: rays that never meet a cell end at
  // once (paths_ended). `job_done` fills a finished job's `out` and `counts` where the
  // engine has not (the renderer's kernels already have; the twin looks them up).
  virtual Counts make_camera_rays(std::uint64_t first, std::uint64_t n) = 0;
  virtual void job_done(Job&) {}

  static std::size_t queue_of(const Ray& r) { return std::size_t(r.cell) * kBatchSlots + std::size_t(Traits::slot(r)); }
  std::size_t queue_count() const { return staging_.size() * kBatchSlots; }
  Staged& queue(std::size_t q) { return staging_[q / kBatchSlots][q % kBatchSlots]; }
  void count_staged(std::uint64_t n) { staged_ += n; }

 private:
  // Camera rays in sample-major scanline order (coherent waves), while paths_alive < cap.
  void generate(Time now, JobPool& pool) {
    if (aborted_) return;
    if (opt_.camera_jobs) {
      const std::uint64_t size = std::clamp<std::uint64_t>(opt_.path_cap / (4 * std::max<std::size_t>(1, g_.computes.size())),
                                                           std::min(opt_.min_batch, opt_.max_batch), opt_.max_batch);
      while (next_camera_ < total_camera_ && paths_alive_ < opt_.path_cap) {
        const std::uint64_t n = std::min({total_camera_ - next_camera_, opt_.path_cap - paths_alive_, size});
        make_camera_job(next_camera_, n, now, pool, true);
        next_camera_ += n;
      }
      return;
    }
    while (next_camera_ < total_camera_ && paths_alive_ < opt_.path_cap) {
      const std::uint64_t n = std::min<std::uint64_t>(total_camera_ - next_camera_, opt_.path_cap - paths_alive_);
      const Counts c = make_camera_rays(next_camera_, n);
      paths_alive_ += n - c.paths_ended;
      counts_ += c;
      next_camera_ += n;
    }
  }

  void stage(std::vector<Ray>& rays) {
    // Count first so a queue grows at most once per call (a job's output would otherwise
    // reallocate its queues many times, page faults included).
    std::vector<std::uint32_t> add(queue_count(), 0);
    for (const Ray& r : rays) ++add[queue_of(r)];
    for (std::size_t q = 0; q < add.size(); ++q)
      if (add[q]) queue(q).reserve_more(add[q]);
    for (const Ray& r : rays) queue(queue_of(r)).v.push_back(r);
    staged_ += rays.size();
    rays.clear();
    rays.shrink_to_fit();
  }

  // A job into the pool, with its (empty) rays and outputs kept here under its id.
  JobId add_job(JobPool& pool, rayline::Job j) {
    const JobId id = pool.add_job(std::move(j));
    if (static_cast<std::size_t>(id) >= jobs_.size()) jobs_.resize(static_cast<std::size_t>(id) + 1);
    jobs_[static_cast<std::size_t>(id)] = std::make_unique<Job>();
    return id;
  }

  // A RayIntersect E-job on the one cell that makes camera rays [first, first + n) itself:
  // its input is the scene block alone (the rays never wait in a queue); its n paths are
  // alive from now on (`fresh`; a lost job's range is made again, already counted).
  void make_camera_job(std::uint64_t first, std::uint64_t n, Time now, JobPool& pool, bool fresh) {
    rayline::Job j;
    j.name = "camera" + std::to_string(first);
    j.type = type_[0];
    j.inputs = {scene_blocks_[0]};
    j.created = now;
    j.work = n;
    Job& cj = job(add_job(pool, std::move(j)));
    cj.camera_first = first, cj.camera_count = n;
    cj.input = n;
    in_jobs_ += n;
    if (fresh) paths_alive_ += n;
    ++jobs_created_;
  }

  void make_job(int k, std::uint32_t cell, Staged& rays, std::size_t n, Time now, JobPool& pool, Schedule& s) {
    const bool path = k % 2 == 0;
    DataBlock q;
    q.name = std::string(path ? "rays" : "shadow") + std::to_string(cell) + "." + std::to_string(pool.block_count());
    q.kind = path ? DataKind::RayQueue : DataKind::ShadowRayQueue;
    q.bytes = n * kRayRecordBytes;
    q.consumed = true;
    q.scene_block = scene_blocks_[cell];
    const BlockId qb = pool.add_block(q);
    s.put_initial(qb, ram_, now, false);

    Job* target = nullptr;
    const JobId open = open_[cell][k];
    if (open != kNone && pool.state(open) == JobState::Queued && job(open).rays.size() + n <= opt_.max_batch) {
      // Sec. 5.1: the queue merges into the queued job that already holds one for this cell.
      pool.add_input(open, qb);
      pool.job(open).work += n;
      target = &job(open);
      consumer_[qb] = open;
      ++merges_;
    } else {
      rayline::Job j;
      j.name = std::string(path ? "ri" : "si") + (k >= 2 ? "cpu" : "") + std::to_string(cell);
      j.type = type_[k];
      j.inputs = {scene_blocks_[cell], qb};
      j.created = now;
      j.work = n;
      const JobId id = add_job(pool, std::move(j));
      target = &job(id);
      target->slot = k;
      target->cell = cell;
      consumer_[qb] = id;
      open_[cell][k] = id;
      ++jobs_created_;
    }
    // Take the first n staged rays (FIFO keeps the order deterministic; order does not
    // change the image anyway). A whole queue into a fresh job moves without a copy.
    if (target->rays.empty() && rays.head == 0 && n == rays.v.size()) {
      target->rays = std::move(rays.v);
      rays.v = {};
    } else {
      const auto first = rays.v.begin() + static_cast<std::ptrdiff_t>(rays.head);
      target->rays.insert(target->rays.end(), first, first + static_cast<std::ptrdiff_t>(n));
      rays.head += n;
      if (rays.head == rays.v.size()) {
        rays.v.clear();
        rays.head = 0;
      } else if (2 * rays.head >= rays.v.size()) {
        rays.v.erase(rays.v.begin(), rays.v.begin() + static_cast<std::ptrdiff_t>(rays.head));
        rays.head = 0;
      }
    }
    target->input += n;
    target->parts.emplace_back(qb, static_cast<std::uint32_t>(n));
    staged_ -= n;
    in_jobs_ += n;
  }

  void flush(Time now, JobPool& pool, Schedule& s, bool all) {
    // CPU-only queues (slots 2, 3) count as resident only where a CPU works: in RAM.
    auto resident = [&](std::uint32_t c, int k) {
      if (k >= 2) return s.copy_at(scene_blocks_[c], ram_) != nullptr;
      for (MemId m : near_)
        if (s.copy_at(scene_blocks_[c], m) != nullptr) return true;
      return false;
    };
    const std::size_t big_batch = std::min<std::size_t>(opt_.max_batch, std::size_t(opt_.min_batch) * 16);
    for (std::uint32_t c = 0; c < staging_.size(); ++c)
      for (int k = 0; k < kBatchSlots; ++k) {
        auto& v = staging_[c][k];
        if (v.empty()) continue;
        const std::size_t threshold = resident(c, k) ? opt_.min_batch : big_batch;
        while (v.size() >= threshold || (all && !v.empty()))
          make_job(k, c, v, std::min<std::size_t>(v.size(), opt_.max_batch), now, pool, s);
      }
    // Keep every compute device fed: the largest remaining queues become jobs, those of
    // resident cells first.
    while (pool.queued_count() < g_.computes.size() && staged_ > 0) {
      std::size_t best = 0;
      std::uint32_t bc = 0;
      int bk = 0;
      bool best_res = false;
      for (std::uint32_t c = 0; c < staging_.size(); ++c) {
        for (int k = 0; k < kBatchSlots; ++k) {
          const std::size_t n = staging_[c][k].size();
          if (n == 0) continue;
          const bool res = resident(c, k);
          if ((res && !best_res) || (res == best_res && n > best)) best = n, bc = c, bk = k, best_res = res;
        }
      }
      // A cell that is not resident is loaded only when nothing is queued at all.
      if (!best_res && pool.queued_count() > 0) break;
      make_job(bk, bc, staging_[bc][bk], std::min<std::size_t>(best, opt_.max_batch), now, pool, s);
    }
  }

  const DeviceGraph& g_;
  MemId ram_;
  std::vector<MemId> near_;  // memories compute devices work from (RAM, GPU memories)
  std::vector<BlockId> scene_blocks_;
  RayBatchOptions opt_;
  JobTypeId type_[kBatchSlots];
  std::vector<std::array<Staged, kBatchSlots>> staging_;  // per cell, per slot
  std::vector<std::array<JobId, kBatchSlots>> open_;       // queued job per cell, slot
  std::vector<std::unique_ptr<Job>> jobs_;                 // by JobId
  std::unordered_map<BlockId, JobId> consumer_;            // ray queue -> its job
  Counts counts_{};
  std::uint64_t next_camera_ = 0, total_camera_ = 0;
  std::uint64_t first_wave_ = 0;  // first_wave()
  std::uint64_t paths_alive_ = 0, staged_ = 0, in_jobs_ = 0;
  std::uint64_t merges_ = 0, jobs_created_ = 0;
  bool aborted_ = false;
};

}  // namespace rayline

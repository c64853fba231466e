#include "render/engine/render_workload.hpp"

#include <algorithm>
#include <numeric>

#include <tbb/parallel_for.h>

#include "render/engine/profile_recorder.hpp"

namespace rayline::engine {

using trace::RayKind;
using trace::RayRecord;

RenderWorkload::RenderWorkload(const trace::TraceSettings& ts, const trace::PinholeCamera& camera,
                               const DeviceGraph& g, MemId ram, std::vector<BlockId> scene_blocks,
                               RenderWorkloadOptions opt)
    : ts_(ts), camera_(camera), g_(g), ram_(ram), scene_blocks_(std::move(scene_blocks)), opt_(opt),
      staging_(scene_blocks_.size()), open_(scene_blocks_.size(), {kNone, kNone, kNone, kNone}) {
  type_[0] = g.job_type("RayIntersect");
  type_[1] = g.job_type("ShadowIntersect");
  type_[2] = g.job_type("RayIntersectCpu");
  type_[3] = g.job_type("ShadowIntersectCpu");
  if (type_[2] == kNone || type_[3] == kNone) type_[2] = type_[0], type_[3] = type_[1];
  for (std::size_t m = 0; m < g.memories.size(); ++m)
    if (!g.computes_on(MemId(m)).empty()) near_.push_back(MemId(m));
  total_camera_ = std::uint64_t(camera.width()) * std::uint64_t(camera.height()) * std::uint64_t(opt_.spp);
}

void RenderWorkload::start(Time now, JobPool& pool, Schedule& s) {
  generate();
  flush(now, pool, s, false);
}

bool RenderWorkload::finished() const {
  return aborted_ || (next_camera_ == total_camera_ && staged_ == 0 && in_jobs_ == 0);
}

// Camera rays in sample-major scanline order (coherent waves), while paths_alive < cap.
// A round generates what the cap allows, in chunks of 8192 rays on oneTBB's threads (each
// chunk its own vector and counts, and its rays' indices grouped by queue; the film's
// sample counts are atomic), then stages them queue by queue, also on oneTBB's threads:
// each queue appends its rays chunk by chunk in order, so every queue holds the same rays
// in the same order as one thread would make. Out of core the first wave is every path
// that fits (renderer.cpp), all 1 M rays at 10 M triangles and a 25 % budget: ≈ 1 s before
// the first load could start when staged on one thread, most of it first touches of the
// queues' pages.
void RenderWorkload::generate() {
  if (aborted_) return;
  const std::uint64_t pixels = std::uint64_t(camera_.width()) * std::uint64_t(camera_.height());
  constexpr std::uint64_t kChunk = 8192;
  const std::size_t queues = staging_.size() * kSlots;
  while (next_camera_ < total_camera_ && paths_alive_ < opt_.path_cap) {
    const std::uint64_t n = std::min<std::uint64_t>(total_camera_ - next_camera_, opt_.path_cap - paths_alive_);
    const std::size_t chunks = static_cast<std::size_t>((n + kChunk - 1) / kChunk);
    std::vector<std::vector<RayRecord>> fresh(chunks);
    std::vector<trace::RayCounts> counts(chunks);
    // Per chunk: its rays' indices grouped by queue (cell * kSlots + slot), in ray order
    // within a queue, and each queue's start in that list (queues + 1 entries).
    std::vector<std::vector<std::uint32_t>> order(chunks), start(chunks);
    const std::uint64_t first = next_camera_;
    auto begin = [&](std::size_t k) { return first + k * kChunk; };
    auto end = [&](std::size_t k) { return std::min(first + n, begin(k) + kChunk); };
    tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t k) {
      for (std::uint64_t i = begin(k); i < end(k); ++i) {
        const auto pixel = static_cast<std::uint32_t>(i % pixels), sample = static_cast<std::uint32_t>(i / pixels);
        trace::generate_camera_ray(ts_, camera_.position(), camera_.direction(pixel, sample, ts_.seed), pixel, sample,
                                   fresh[k], counts[k]);
      }
      auto& st = start[k];
      st.assign(queues + 1, 0);
      for (const RayRecord& r : fresh[k]) ++st[queue_of(r) + 1];
      for (std::size_t q = 0; q < queues; ++q) st[q + 1] += st[q];
      std::vector<std::uint32_t> next(st.begin(), st.end() - 1);
      order[k].resize(fresh[k].size());
      for (std::uint32_t j = 0; j < fresh[k].size(); ++j)
        order[k][next[queue_of(fresh[k][j])]++] = j;
    });
    for (std::size_t k = 0; k < chunks; ++k) {
      if (opt_.recorder) opt_.recorder->camera_rays(fresh[k], begin(k), end(k) - begin(k), pixels);
      // Camera rays that never meet the scene bounds end at once (escaped).
      paths_alive_ += (end(k) - begin(k)) - counts[k].paths_ended;
      counts_ += counts[k];
      staged_ += fresh[k].size();
    }
    tbb::parallel_for(std::size_t(0), queues, [&](std::size_t q) {
      std::size_t add = 0;
      for (std::size_t k = 0; k < chunks; ++k) add += start[k][q + 1] - start[k][q];
      if (add == 0) return;
      Staged& st = queue(q);
      st.reserve_more(add);
      for (std::size_t k = 0; k < chunks; ++k)
        for (std::uint32_t j = start[k][q]; j < start[k][q + 1]; ++j) st.v.push_back(fresh[k][order[k][j]]);
    });
    next_camera_ += n;
  }
}

void RenderWorkload::stage(std::vector<RayRecord>& rays) {
  // Count first so a queue grows at most once per call (a job's output would otherwise
  // reallocate its queues many times, page faults included).
  std::vector<std::uint32_t> add(staging_.size() * kSlots, 0);
  for (const RayRecord& r : rays) ++add[queue_of(r)];
  for (std::size_t q = 0; q < add.size(); ++q)
    if (add[q]) queue(q).reserve_more(add[q]);
  for (const RayRecord& r : rays) queue(queue_of(r)).v.push_back(r);
  staged_ += rays.size();
  rays.clear();
  rays.shrink_to_fit();
}

void RenderWorkload::make_job(int k, std::uint32_t cell, Staged& rays, std::size_t n, Time now, JobPool& pool,
                              Schedule& s) {
  const RayKind kind = static_cast<RayKind>(k % 2);
  DataBlock q;
  q.name = std::string(kind == RayKind::Path ? "rays" : "shadow") + std::to_string(cell) + "." +
           std::to_string(pool.block_count());
  q.kind = kind == RayKind::Path ? DataKind::RayQueue : DataKind::ShadowRayQueue;
  q.bytes = n * sizeof(RayRecord);
  q.consumed = true;
  q.scene_block = scene_blocks_[cell];
  const BlockId qb = pool.add_block(q);
  s.put_initial(qb, ram_, now, false);

  RayJob* target = nullptr;
  const JobId open = open_[cell][k];
  if (open != kNone && pool.state(open) == JobState::Queued && job(open).rays.size() + n <= opt_.max_batch) {
    // Sec. 5.1: the queue merges into the queued job that already holds one for this cell.
    pool.add_input(open, qb);
    pool.job(open).work += n;
    target = &job(open);
    consumer_[qb] = open;
    ++merges_;
  } else {
    Job j;
    j.name = std::string(kind == RayKind::Path ? "ri" : "si") + (k >= 2 ? "cpu" : "") + std::to_string(cell);
    j.type = type_[k];
    j.inputs = {scene_blocks_[cell], qb};
    j.created = now;
    j.work = n;
    const JobId id = pool.add_job(std::move(j));
    if (static_cast<std::size_t>(id) >= jobs_.size()) jobs_.resize(static_cast<std::size_t>(id) + 1);
    jobs_[static_cast<std::size_t>(id)] = std::make_unique<RayJob>();
    target = jobs_[static_cast<std::size_t>(id)].get();
    target->kind = kind;
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

void RenderWorkload::flush(Time now, JobPool& pool, Schedule& s, bool all) {
  // Out of core, every job on a block that is not in RAM costs a load (Sec. 5.1: batch rays
  // to amortise data movement). Queues of resident cells (held or arriving on RAM in the
  // plan) become jobs at min_batch rays; queues of other cells wait for big_batch rays.
  // CPU-only queues (slots 2, 3) count as resident only where a CPU works: in RAM.
  auto resident = [&](std::uint32_t c, int k) {
    if (k >= 2) return s.copy_at(scene_blocks_[c], ram_) != nullptr;
    for (MemId m : near_)
      if (s.copy_at(scene_blocks_[c], m) != nullptr) return true;
    return false;
  };
  const std::size_t big_batch = std::min<std::size_t>(opt_.max_batch, std::size_t(opt_.min_batch) * 16);
  for (std::uint32_t c = 0; c < staging_.size(); ++c)
    for (int k = 0; k < kSlots; ++k) {
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
      for (int k = 0; k < kSlots; ++k) {
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

void RenderWorkload::on_job_finished(JobId j, Time now, JobPool& pool, Schedule& s) {
  if (static_cast<std::size_t>(j) >= jobs_.size() || !jobs_[static_cast<std::size_t>(j)]) return;
  std::unique_ptr<RayJob> done = std::move(jobs_[static_cast<std::size_t>(j)]);
  counts_ += done->counts;
  for (const auto& part : done->parts) consumer_.erase(part.first);
  in_jobs_ -= done->input;
  paths_alive_ -= done->counts.paths_ended;
  stage(done->out);
  done.reset();
  generate();
  flush(now, pool, s, false);
}

void RenderWorkload::on_idle(Time now, JobPool& pool, Schedule& s) {
  generate();
  flush(now, pool, s, true);
}

}  // namespace rayline::engine

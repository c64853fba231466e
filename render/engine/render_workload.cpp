#include "render/engine/render_workload.hpp"

#include <tbb/parallel_for.h>

#include "render/engine/profile_recorder.hpp"
#include "render/engine/ray_log_recorder.hpp"

namespace rayline::engine {

using trace::RayRecord;

RenderWorkload::RenderWorkload(const trace::TraceSettings& ts, const trace::PinholeCamera& camera,
                               const DeviceGraph& g, MemId ram, std::vector<BlockId> scene_blocks,
                               RenderWorkloadOptions opt)
    : RayBatchWorkload(g, ram, std::move(scene_blocks), opt,
                       std::uint64_t(camera.width()) * std::uint64_t(camera.height()) * std::uint64_t(opt.spp)),
      ts_(ts), camera_(camera),
      order_{std::uint32_t(camera.width()), std::uint32_t(camera.height()), std::uint32_t(opt.spp)},
      recorder_(opt.recorder), ray_log_(opt.ray_log) {}

// A wave of camera rays in chunks of 8192 on oneTBB's threads (each chunk its own vector
// and counts, and its rays' indices grouped by queue; the film's sample counts are
// atomic), then staged queue by queue, also on oneTBB's threads: each queue appends its
// rays chunk by chunk in order, so every queue holds the same rays in the same order as
// one thread would make. Out of core the first wave is every path that fits
// (renderer.cpp), all 1 M rays at 10 M triangles and a 25 % budget: ≈ 1 s before the
// first load could start when staged on one thread, most of it first touches of the
// queues' pages.
trace::RayCounts RenderWorkload::make_camera_rays(std::uint64_t first, std::uint64_t n) {
  const std::uint64_t pixels = std::uint64_t(camera_.width()) * std::uint64_t(camera_.height());
  constexpr std::uint64_t kChunk = 8192;
  const std::size_t queues = queue_count();
  const std::size_t chunks = static_cast<std::size_t>((n + kChunk - 1) / kChunk);
  std::vector<std::vector<RayRecord>> fresh(chunks);
  std::vector<trace::RayCounts> counts(chunks);
  // Per chunk: its rays' indices grouped by queue (cell * kBatchSlots + slot), in ray order
  // within a queue, and each queue's start in that list (queues + 1 entries).
  std::vector<std::vector<std::uint32_t>> order(chunks), start(chunks);
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
    for (std::uint32_t j = 0; j < fresh[k].size(); ++j) order[k][next[queue_of(fresh[k][j])]++] = j;
  });
  trace::RayCounts total;
  for (std::size_t k = 0; k < chunks; ++k) {
    if (recorder_) recorder_->camera_rays(fresh[k], begin(k), end(k) - begin(k), pixels);
    if (ray_log_) ray_log_->camera_rays(fresh[k]);
    total += counts[k];
    count_staged(fresh[k].size());
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
  return total;
}

void RenderWorkload::camera_job_rays(const trace::TraceSettings& ts, std::uint64_t first, std::uint64_t n,
                                     std::vector<RayRecord>& placed, trace::RayCounts& counts) const {
  const trace::SeedKey key(ts.seed);
  CameraOrder::Walk w = order_.walk(first);
  for (std::uint64_t j = 0; j < n; ++j, w.next())
    trace::generate_camera_ray(ts, camera_.position(), camera_.direction(w.x, w.y, w.sample, key), w.pixel(), w.sample,
                               placed, counts);
}

void RenderWorkload::job_done(RayJob& job) {
  if (!ray_log_) return;
  // A pass without input rays is a camera job's camera rays (activity_tasks.cpp).
  for (const auto& [in, out] : job.log_passes) {
    if (in.empty()) ray_log_->camera_rays(out);
    else ray_log_->job(job.cell, in, out);
  }
  decltype(job.log_passes)().swap(job.log_passes);
}

}  // namespace rayline::engine

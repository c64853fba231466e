#include "render/accel/vulkan_aggregate.hpp"

#include <algorithm>

#include <tbb/parallel_for.h>

namespace rayline::accel {

using trace::RayKind;
using trace::RayRecord;

void VulkanAggregate::run(const trace::TraceSettings& ts, const QueueJob& job, std::vector<RayRecord>& out,
                          trace::RayCounts& counts) {
  std::shared_ptr<const gpu::GpuBlock> block = gpu_.resident(job.cell);
  Answers answers;
  double kernel = 0;
  std::uint64_t on_gpu = 0, fallback = 0, doubtful = 0;
  std::size_t off = 0;
  for (const auto& [queue, n] : job.parts) {
    const std::span<const RayRecord> part = job.rays.subspan(off, n);
    off += n;
    std::unique_ptr<gpu::GpuRays> up = gpu_.take_rays(queue);
    // After a failure this queue and the rest run on the CPU path.
    if (block && !search(ts, job.kind, *block, part, up, answers, kernel)) block.reset();
    if (!block) {
      // Embree on the RAM copy (loaded on the spot if the plan evicted it).
      cpu_.intersect(ts, QueueJob{job.cell, job.kind, part, {}}, out, counts);
      fallback += n;
      continue;
    }
    on_gpu += n;
    doubtful += resolve(ts, job.kind, part, answers, out, counts);
  }
  gpu_.note_job(job.rays.size(), on_gpu, fallback, doubtful, kernel);
}

bool VulkanAggregate::search(const trace::TraceSettings& ts, RayKind kind, const gpu::GpuBlock& block,
                             std::span<const RayRecord> part, std::unique_ptr<gpu::GpuRays>& up, Answers& answers,
                             double& kernel_seconds) {
  try {
    if (!up) up = gpu_.upload_unplanned(part, ts);  // the T-job failed or was not planned
    if (kind == RayKind::Path) {
      answers.hits.resize(part.size());
      kernel_seconds += gpu::intersect_closest(gpu_.context(), block, *up, answers.hits);
    } else {
      answers.occluded.resize(part.size());
      kernel_seconds += gpu::intersect_any(gpu_.context(), block, *up, answers.occluded);
    }
    return true;
  } catch (const gpu::GpuError& e) {
    gpu_.note_error(e);
    return false;
  }
}

std::uint64_t VulkanAggregate::resolve(const trace::TraceSettings& ts, RayKind kind, std::span<const RayRecord> part,
                                       const Answers& answers, std::vector<RayRecord>& out,
                                       trace::RayCounts& counts) const {
  // In parallel chunks (oneTBB) so one host thread does not bound the GPU; chunk outputs
  // are appended in chunk order (the image does not depend on the order anyway).
  constexpr std::size_t kChunk = 2048;
  const std::size_t chunks = (part.size() + kChunk - 1) / kChunk;
  std::vector<std::vector<RayRecord>> chunk_out(chunks);
  std::vector<trace::RayCounts> chunk_counts(chunks);
  std::vector<std::uint64_t> chunk_doubtful(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    for (std::size_t i = c * kChunk; i < std::min(part.size(), (c + 1) * kChunk); ++i)
      chunk_doubtful[c] += resolve_ray(ts, kind, part[i], answers, i, chunk_out[c], chunk_counts[c]);
  });
  std::uint64_t doubtful = 0;
  for (std::size_t c = 0; c < chunks; ++c) {
    out.insert(out.end(), chunk_out[c].begin(), chunk_out[c].end());
    counts += chunk_counts[c];
    doubtful += chunk_doubtful[c];
  }
  return doubtful;
}

bool VulkanAggregate::resolve_ray(const trace::TraceSettings& ts, RayKind kind, const RayRecord& r,
                                  const Answers& answers, std::size_t i, std::vector<RayRecord>& out,
                                  trace::RayCounts& counts) const {
  const bool doubt =
      kind == RayKind::Path ? gpu::doubtful(answers.hits[i]) : (answers.occluded[i] & gpu::kAnyDoubtful) != 0;
  if (doubt && resolve_doubtful_) {
    // Not traced here: back as it came, flagged for a CPU device, which traces it with
    // exactly the CPU-only render's arithmetic (Embree + tie filter).
    out.push_back(r);
    out.back().flags |= trace::kRayCpuOnly;
    return true;
  }
  if (kind == RayKind::Shadow) {
    trace::after_occlusion_test(ts, r, (answers.occluded[i] & gpu::kAnyOccluded) != 0, out, counts);
    return doubt;
  }
  // The closest-hit kernel returns the hit triangle itself, so shading needs no RAM copy.
  const gpu::GpuHit& h = answers.hits[i];
  if (h.prim == gpu::kNoHit) {
    trace::after_closest_hit(ts, r, nullptr, 0.0f, out, counts);
    return doubt;
  }
  const trace::HitTriangle tri{{h.v[0], h.v[1], h.v[2]}, {h.v[3], h.v[4], h.v[5]}, {h.v[6], h.v[7], h.v[8]},
                               h.material};
  trace::after_closest_hit(ts, r, &tri, gpu::hit_t(h), out, counts);
  return doubt;
}

}  // namespace rayline::accel

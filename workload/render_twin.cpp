#include "workload/render_twin.hpp"

#include <stdexcept>
#include <utility>

namespace rayline {

RenderTwinWorkload::RenderTwinWorkload(const DeviceGraph& g, MemId ram, std::vector<BlockId> scene_blocks,
                                       RayBatchOptions opt, std::unique_ptr<TwinOracle> oracle)
    : RayBatchWorkload(g, ram, std::move(scene_blocks), opt, oracle->camera_rays()), oracle_(std::move(oracle)) {
  if (opt.spp != int(oracle_->spp()))
    throw std::invalid_argument("render twin: spp " + std::to_string(opt.spp) + " but the oracle has " +
                                std::to_string(oracle_->spp()));
}

TwinCounts RenderTwinWorkload::make_camera_rays(std::uint64_t first, std::uint64_t n) {
  TwinCounts c;
  std::uint64_t staged = 0;
  for (std::uint64_t i = first; i < first + n; ++i) {
    TwinRay r;
    if (!oracle_->entry(i, r)) {
      ++c.paths_ended;  // missed the scene: ended at once
      continue;
    }
    queue(queue_of(r)).v.push_back(r);
    ++staged;
  }
  count_staged(staged);
  return c;
}

void RenderTwinWorkload::job_done(Job& job) {
  job.out.clear();
  for (const TwinRay& r : job.rays) {
    const std::size_t before = job.out.size();
    oracle_->visit(r, job.out);
    ++job.counts.traced;
    if (job.out.size() == before) ++job.counts.ended_here;
    // A path ray that handed on no path ray ended its path (shadow rays never do).
    bool continues = r.kind != 0;
    for (std::size_t k = before; k < job.out.size(); ++k) continues = continues || job.out[k].kind == 0;
    if (!continues) ++job.counts.paths_ended;
  }
  std::vector<TwinRay>().swap(job.rays);
}

}  // namespace rayline

#include "workload/render_twin.hpp"

#include <stdexcept>
#include <utility>

namespace rayline {

RenderTwinWorkload::RenderTwinWorkload(const DeviceGraph& g, MemId ram, std::vector<BlockId> scene_blocks,
                                       RayBatchOptions opt, std::shared_ptr<const RayLog> log)
    : RayBatchWorkload(g, ram, std::move(scene_blocks), opt, log->camera_rays()), log_(std::move(log)) {
  if (opt.spp != int(log_->spp))
    throw std::invalid_argument("render twin: spp " + std::to_string(opt.spp) + " but the ray log has " +
                                std::to_string(log_->spp));
}

TwinCounts RenderTwinWorkload::make_camera_rays(std::uint64_t first, std::uint64_t n) {
  TwinCounts c;
  std::uint64_t staged = 0;
  for (std::uint64_t i = first; i < first + n; ++i) {
    const std::uint32_t v = log_->entry[i];
    if (v == RayLog::kNoVisit) {
      ++c.paths_ended;  // missed the scene: ended at once
      continue;
    }
    const RayVisit& rv = log_->visits[v];
    TwinRay r{v, rv.cell, rv.kind};
    queue(queue_of(r)).v.push_back(r);
    ++staged;
  }
  count_staged(staged);
  return c;
}

void RenderTwinWorkload::job_done(Job& job) {
  const RayLog& log = *log_;
  job.out.clear();
  for (const TwinRay& r : job.rays) {
    const RayVisit& v = log.visits[r.visit];
    ++job.counts.traced;
    if (v.children == 0) ++job.counts.ended_here;
    if (log.ends_path(v)) ++job.counts.paths_ended;
    for (std::uint32_t k = 0; k < v.children; ++k) {
      const std::uint32_t w = log.children[v.first + k];
      const RayVisit& c = log.visits[w];
      job.out.push_back(TwinRay{w, c.cell, c.kind});
    }
  }
  std::vector<TwinRay>().swap(job.rays);
}

}  // namespace rayline

#include "workload/render_twin.hpp"

#include <stdexcept>
#include <utility>

#include "workload/camera_order.hpp"

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

// Under continue_in_cell the rays a visit hands on in the job's own cell are visited in the
// same job, as the renderer's CPU aggregate traces them (render/accel/aggregate.cpp); only
// rays for other cells leave through `out`.
void RenderTwinWorkload::job_done(Job& job) {
  job.out.clear();
  // A camera job's rays: the oracle's entries of its camera rays (in the camera order,
  // workload/camera_order.hpp), made in the job.
  const CameraOrder order{oracle_->width(), oracle_->height(), oracle_->spp()};
  for (std::uint64_t j = job.camera_first; j < job.camera_first + job.camera_count; ++j) {
    TwinRay r;
    if (oracle_->entry(order.camera_index(j), r)) job.rays.push_back(r);
    else ++job.counts.paths_ended;  // missed the scene: ended at once
  }
  const bool stay = options().continue_in_cell;
  std::vector<TwinRay> made;
  for (std::size_t i = 0; i < job.rays.size(); ++i) {
    const TwinRay r = job.rays[i];  // job.rays may grow below
    made.clear();
    oracle_->visit(r, made);
    ++job.counts.traced;
    if (made.empty()) ++job.counts.ended_here;
    // A path ray that handed on no path ray ended its path (shadow rays never do).
    bool continues = r.kind != 0;
    for (const TwinRay& m : made) {
      continues = continues || m.kind == 0;
      if (stay && m.cell == job.cell) job.rays.push_back(m);
      else job.out.push_back(m);
    }
    if (!continues) ++job.counts.paths_ended;
  }
  std::vector<TwinRay>().swap(job.rays);
}

}  // namespace rayline

#include "render/accel/embree_aggregate.hpp"

#include "render/embree/embree_kernels.hpp"

namespace rayline::accel {

void EmbreeAggregate::intersect_closest(const trace::TraceSettings& ts, const QueueJob& job,
                                        std::vector<trace::RayRecord>& out, trace::RayCounts& counts) {
  const auto geo = ram_.get(job.cell);
  trace::ray_intersect(ts, *geo, job.rays, out, counts);
}

void EmbreeAggregate::intersect_shadow(const trace::TraceSettings& ts, const QueueJob& job,
                                       std::vector<trace::RayRecord>& out, trace::RayCounts& counts) {
  const auto geo = ram_.get(job.cell);
  trace::shadow_intersect(ts, *geo, job.rays, out, counts);
}

}  // namespace rayline::accel

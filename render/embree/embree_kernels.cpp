#include "render/embree/embree_kernels.hpp"

#include <embree3/rtcore.h>

#include "render/embree/tie_break.hpp"

namespace rayline::trace {

namespace {

// The Embree query interval of a ray in its cell: the cell's (tnear, texit] widened by
// delta(t) on both sides (never before the ray's own start). Embree decides range
// membership on unnormalised values, so a hit exactly on a split plane could otherwise be
// rejected by both cells. With the overlap, and triangles within the partitioner's eps
// band of a plane referenced on both sides, the first cell along the ray that reports a
// hit reports the globally closest one — the same triangle and t for any partition.
RTCRay to_rtc(const TraceSettings& ts, const RayRecord& r) {
  RTCRay x;
  x.org_x = r.org.x, x.org_y = r.org.y, x.org_z = r.org.z;
  x.dir_x = r.dir.x, x.dir_y = r.dir.y, x.dir_z = r.dir.z;
  query_interval(ts, r, x.tnear, x.tfar);
  x.time = 0;
  x.mask = 0xFFFFFFFFu;
  x.id = 0;
  x.flags = 0;
  return x;
}

// Rays of one queue go in all directions (secondary and shadow rays).
RTCIntersectContext incoherent_context() {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  return ctx;
}

}  // namespace

void ray_intersect(const TraceSettings& ts, const BlockGeometry& block, std::span<const RayRecord> rays,
                   std::vector<RayRecord>& out, RayCounts& counts) {
  TieBreakContext tie;  // the GPU kernel's tie rule (tie_break.hpp)
  tie.ctx = incoherent_context();
  auto scene = static_cast<RTCScene>(block.scene());
  for (const RayRecord& r : rays) {
    if (scene) {
      RTCRayHit rh;
      rh.ray = to_rtc(ts, r);
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
      tie.reset();
      rtcIntersect1(scene, &tie.ctx, &rh);
      if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        const std::uint32_t prim = rh.hit.primID;
        const HitTriangle h{block.vertex(prim, 0), block.vertex(prim, 1), block.vertex(prim, 2), block.material(prim)};
        after_closest_hit(ts, r, &h, rh.ray.tfar, out, counts);
        continue;
      }
    }
    after_closest_hit(ts, r, nullptr, 0.0f, out, counts);
  }
}

void shadow_intersect(const TraceSettings& ts, const BlockGeometry& block, std::span<const RayRecord> rays,
                      std::vector<RayRecord>& out, RayCounts& counts) {
  RTCIntersectContext ctx = incoherent_context();
  auto scene = static_cast<RTCScene>(block.scene());
  for (const RayRecord& r : rays) {
    bool occluded = false;
    if (scene) {
      RTCRay ray = to_rtc(ts, r);
      rtcOccluded1(scene, &ctx, &ray);
      occluded = ray.tfar < 0;
    }
    after_occlusion_test(ts, r, occluded, out, counts);
  }
}

}  // namespace rayline::trace

// The E-jobs of ray batching on the CPU (Fig. 3, Sec. 3.1): every ray of a queue searched
// in one resident block's Embree BVH (Sec. 6: "each block has its own BVH"), one ray at a
// time (camera rays a packet at a time), each handed to the integrator at once
// (render/integrator/path_kernels.hpp), so Embree's hit is shaded while the ray is still
// in cache.
#pragma once
#include <span>
#include <vector>

#include "render/embree/block_geometry.hpp"
#include "render/integrator/path_kernels.hpp"

namespace rayline::trace {

// RayIntersect: the closest hit of each ray in `block` (ties: the smaller prim,
// tie_break.hpp), then after_closest_hit, in the order of `rays`. `coherent`: rays in
// camera order, searched 8 at a time as one packet (rtcIntersect8), which shares the
// traversal of neighbouring rays; the hits are the same as one ray at a time.
void ray_intersect(const TraceSettings& ts, const BlockGeometry& block, std::span<const RayRecord> rays,
                   std::vector<RayRecord>& out, RayCounts& counts, bool coherent = false);

// ShadowIntersect: whether anything in `block` blocks each ray, then after_occlusion_test.
// (One ray at a time: the shadow rays of camera hits traced as packets of 8 measured 4-10 %
// slower in core on the bunny and the dragon.)
void shadow_intersect(const TraceSettings& ts, const BlockGeometry& block, std::span<const RayRecord> rays,
                      std::vector<RayRecord>& out, RayCounts& counts);

}  // namespace rayline::trace

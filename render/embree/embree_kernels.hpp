// The E-jobs of ray batching on the CPU (Fig. 3, Sec. 3.1): every ray of a queue searched
// in one resident block's Embree BVH (Sec. 6: "each block has its own BVH"), one ray at a
// time, each handed to the integrator at once (render/integrator/path_kernels.hpp), so
// Embree's hit is shaded while the ray is still in cache.
#pragma once
#include <span>
#include <vector>

#include "render/embree/block_geometry.hpp"
#include "render/integrator/path_kernels.hpp"

namespace rayline::trace {

// RayIntersect: the closest hit of each ray in `block` (ties: the smaller prim,
// tie_break.hpp), then after_closest_hit.
void ray_intersect(const TraceSettings& ts, const BlockGeometry& block, std::span<const RayRecord> rays,
                   std::vector<RayRecord>& out, RayCounts& counts);

// ShadowIntersect: whether anything in `block` blocks each ray, then after_occlusion_test.
void shadow_intersect(const TraceSettings& ts, const BlockGeometry& block, std::span<const RayRecord> rays,
                      std::vector<RayRecord>& out, RayCounts& counts);

}  // namespace rayline::trace

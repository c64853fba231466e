// The closest-hit tie rule shared with the GPU kernel (render/vulkan/shaders/traverse.comp):
// of two triangles met at exactly the same t, the smaller prim wins — whatever order the
// traversal meets them in. Embree keeps the last candidate it accepts, so an intersection
// filter (block_geometry.cpp) rejects a candidate at the current best t with a larger prim;
// the per-ray best lives in this extended intersect context (the usual Embree 3 idiom).
// Included only by .cpp files that use Embree.
#pragma once
#include <embree3/rtcore.h>

#include <limits>

namespace rayline::trace {

struct TieBreakContext {
  RTCIntersectContext ctx;  // first member: Embree passes &ctx to the filter
  float best_t = std::numeric_limits<float>::infinity();
  unsigned best_prim = RTC_INVALID_GEOMETRY_ID;
  void reset() {
    best_t = std::numeric_limits<float>::infinity();
    best_prim = RTC_INVALID_GEOMETRY_ID;
  }
};

// The geometry's intersect filter (rtcSetGeometryIntersectFilterFunction).
void smaller_prim_wins_ties(const RTCFilterFunctionNArguments* args);

}  // namespace rayline::trace

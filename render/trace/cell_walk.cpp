#include "render/trace/cell_walk.hpp"

#include <algorithm>
#include <utility>

namespace rayline::trace {

bool enter_cell(const partition::BlockIndex& index, scene::Float3 o, scene::Float3 d, float tmin, float tmax,
                CellSpan& out) {
  if (index.nodes.empty()) return false;
  // Clip to the root cell (slab test, same arithmetic on every call).
  float lo = tmin, hi = tmax;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < index.bounds.lo[a] || o[a] > index.bounds.hi[a]) return false;
      continue;
    }
    float t0 = (index.bounds.lo[a] - o[a]) / d[a], t1 = (index.bounds.hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    lo = std::max(lo, t0), hi = std::min(hi, t1);
  }
  if (!(lo < hi)) return false;
  const float root_lo = lo, root_hi = hi;
  std::uint32_t n = 0;
  while (!index.nodes[n].leaf()) {
    const partition::KdNode& node = index.nodes[n];
    const float oa = o[node.axis], da = d[node.axis];
    if (da == 0) {  // parallel to the plane: stays on its side (ties go right, as locate())
      n = oa < node.split ? node.left : node.right;
      continue;
    }
    const float t = (node.split - oa) / da;
    const std::uint32_t before = da > 0 ? node.left : node.right;  // side the ray comes from
    const std::uint32_t after = da > 0 ? node.right : node.left;
    if (t <= lo) {
      n = after;  // plane already crossed (or behind the origin)
    } else if (t >= hi) {
      n = before;  // not reached within [lo, hi)
    } else {
      n = before;
      hi = t;  // leaves the near child at the plane
    }
  }
  out.cell = index.nodes[n].block;
  // Where the cell's interval meets the scene bounds, it extends to the ray's own ends:
  // every triangle lies inside the bounds, so nothing can be found twice, and a hit
  // computed a few ulps outside the slab test's interval (a wall on the boundary) is kept.
  out.tenter = lo == root_lo ? tmin : lo;
  out.texit = hi == root_hi ? tmax : hi;
  return true;
}

}  // namespace rayline::trace

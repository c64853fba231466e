#include "render/integrator/cell_walk.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "render/partition/occupancy_axis.hpp"

namespace rayline::trace {

bool enter_cell(const partition::BlockIndex& index, scene::Float3 o, scene::Float3 d, float tmin, float tmax,
                CellSpan& out) {
  if (index.nodes.empty()) return false;
  // One cell, a fresh ray (tmin = 0 < tmax) from strictly inside it: every slab's entry
  // (lo - o) / d is behind the origin and its exit ahead (the differences are nonzero and
  // of opposite signs), so the clip below keeps [tmin, tmax] whole; skipped (the shadow
  // and bounce rays of an in-core render, which all start inside the scene). The same
  // answer to the bit (CellWalk.OneCellShortcutIsTheSlabClip).
  if (index.nodes[0].leaf() && tmin == 0 && tmin < tmax) {
    const partition::Bounds& b = index.bounds;
    bool inside = true;
    for (int a = 0; a < 3; ++a) inside = inside && b.lo[a] < o[a] && o[a] < b.hi[a];
    if (inside) {
      out.cell = index.nodes[0].block;
      out.tenter = tmin;
      out.texit = tmax;
      return true;
    }
  }
  // Clip to the root cell (slab test, same arithmetic on every call).
  float lo = tmin, hi = tmax;
  bool thin = false;  // the ray crosses some slab in no time: a flat scene, or one thinner than an ulp of t
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < index.bounds.lo[a] || o[a] > index.bounds.hi[a]) return false;
      continue;
    }
    float t0 = (index.bounds.lo[a] - o[a]) / d[a], t1 = (index.bounds.hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    thin = thin || t0 == t1;
    lo = std::max(lo, t0), hi = std::min(hi, t1);
  }
  // Through a thin root the interval is the single point lo == hi: the ray meets the
  // scene there, in one cell, whose span below then reaches to tmin and tmax.
  if (!(lo < hi || (thin && lo == hi))) return false;
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

namespace {

// Clips [lo, hi] to where o + t·d lies in the box `g` grown by two voxels (`vs`) on every
// side; false when nothing is left. An empty box, or arithmetic that gives no number, leaves
// the interval as it was.
bool clip_to_grown_box(const partition::Bounds& g, const float vs[3], scene::Float3 o, scene::Float3 d, float& lo,
                       float& hi) {
  for (int a = 0; a < 3; ++a)
    if (!(g.lo[a] <= g.hi[a])) return true;
  float l = lo, h = hi;
  for (int a = 0; a < 3; ++a) {
    const float blo = g.lo[a] - 2 * vs[a], bhi = g.hi[a] + 2 * vs[a];
    if (d[a] == 0) {
      if (o[a] < blo || o[a] > bhi) return false;
      continue;
    }
    float ta = (blo - o[a]) / d[a], tb = (bhi - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    l = std::max(l, ta), h = std::min(h, tb);
  }
  if (l > h) return false;
  if (l <= h) lo = l, hi = h;  // (not NaN)
  return true;
}

}  // namespace

bool segment_may_hit(const partition::BlockInfo& block, scene::Float3 o, scene::Float3 d, float t0, float t1) {
  if (!block.has_occupancy) return true;
  constexpr int R = partition::BlockInfo::kOccupancyRes;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const partition::Bounds& c = block.cell;
  float vs[3];
  float lo = t0, hi = t1;
  for (int a = 0; a < 3; ++a) {
    const float ext = c.hi[a] - c.lo[a];
    if (!partition::occupancy_axis_resolved(ext, R)) return true;  // one column along a: every voxel set
    vs[a] = ext / float(R);
    const float glo = c.lo[a] - vs[a], ghi = c.hi[a] + vs[a];  // the cell grown by a voxel
    if (d[a] == 0) {
      if (o[a] < glo || o[a] > ghi) return true;  // cannot be in this cell: do not decide
      continue;
    }
    float ta = (glo - o[a]) / d[a], tb = (ghi - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    lo = std::max(lo, ta), hi = std::min(hi, tb);
  }
  if (!(lo <= hi) || !std::isfinite(lo) || !std::isfinite(hi)) return true;
  // The block's triangles lie in its geometry bounds, and every voxel the grid sets lies
  // within those bounds grown by two voxels (a triangle's voxels, grown by one). Outside that
  // box the segment meets no set voxel, so the walk covers only the part inside it, and a
  // segment that misses it is answered without a walk (half of the cells a ray skips around
  // the dragon in 16 blocks, where the walk would step through every voxel to learn it).
  if (!clip_to_grown_box(block.geometry, vs, o, d, lo, hi)) return false;
  // 3D DDA (Amanatides & Woo) from the clipped segment's start, indices clamped to the grid.
  int i[3], step[3];
  float next[3];
  for (int a = 0; a < 3; ++a) {
    const float p = o[a] + d[a] * lo;
    i[a] = partition::occupancy_voxel(std::floor((p - c.lo[a]) / vs[a]), R, 0);
    step[a] = d[a] > 0 ? 1 : (d[a] < 0 ? -1 : 0);
    next[a] = step[a] == 0 ? kInf : (c.lo[a] + float(i[a] + (step[a] > 0 ? 1 : 0)) * vs[a] - o[a]) / d[a];
  }
  for (int guard = 0; guard < 4 * R; ++guard) {
    const int bit = i[0] + R * (i[1] + R * i[2]);
    if ((block.occupancy[std::size_t(bit / 64)] >> (bit % 64)) & 1) return true;
    const int a = next[0] <= next[1] ? (next[0] <= next[2] ? 0 : 2) : (next[1] <= next[2] ? 1 : 2);
    if (next[a] > hi) return false;  // the rest of the segment stays in this voxel
    i[a] += step[a];
    if (i[a] < 0 || i[a] >= R) {  // into the grown border: those points count in the border voxel
      i[a] = std::clamp(i[a], 0, R - 1);
      next[a] = kInf;
      continue;
    }
    next[a] = (c.lo[a] + float(i[a] + (step[a] > 0 ? 1 : 0)) * vs[a] - o[a]) / d[a];
  }
  return true;
}

}  // namespace rayline::trace

// Empty-space skipping (cell_walk.hpp, segment_may_hit; the grids of partition.hpp): a ray
// may go past a cell only when no triangle of the block can be hit on its segment there.
// Property test against an independent double-precision segment/triangle test.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstdio>
#include <cmath>
#include <random>
#include <vector>

#include "render/partition/partition.hpp"
#include "render/integrator/cell_walk.hpp"

using rayline::partition::BlockInfo;
using rayline::partition::Bounds;
using rayline::partition::mark_occupancy;
using rayline::scene::Float3;
using rayline::trace::segment_may_hit;

namespace {

using D3 = std::array<double, 3>;
D3 sub(D3 a, D3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
D3 cross(D3 a, D3 b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
double dot(D3 a, D3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Möller–Trumbore in double, edges included with a small tolerance: t of the hit or NaN.
double hit_t(D3 o, D3 d, const std::array<D3, 3>& v) {
  const D3 e1 = sub(v[1], v[0]), e2 = sub(v[2], v[0]), p = cross(d, e2);
  const double det = dot(e1, p);
  if (std::fabs(det) < 1e-18) return NAN;
  const D3 s = sub(o, v[0]);
  const double u = dot(s, p) / det;
  const D3 q = cross(s, e1);
  const double w = dot(d, q) / det;
  if (u < -1e-6 || w < -1e-6 || u + w > 1 + 1e-6) return NAN;
  return dot(e2, q) / det;
}

D3 d3(Float3 f) { return {f[0], f[1], f[2]}; }

struct Case {
  Bounds cell;
  BlockInfo block;
  std::vector<std::array<D3, 3>> tris;
};

Case make_case(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0, 1);
  Case c;
  for (int a = 0; a < 3; ++a) {
    c.cell.lo[a] = -5 + 4 * u(rng);
    c.cell.hi[a] = c.cell.lo[a] + 0.5f + 6 * u(rng);
  }
  c.block.cell = c.cell;
  c.block.has_occupancy = true;
  const int n = 1 + int(u(rng) * 12);
  for (int k = 0; k < n; ++k) {
    // Small triangles anywhere in the cell grown by 20 % (some straddle its faces), now and
    // then an axis-aligned one (floors and walls: flat bounds).
    std::array<D3, 3> t;
    Float3 centre;
    for (int a = 0; a < 3; ++a) {
      const float ext = c.cell.hi[a] - c.cell.lo[a];
      centre[a] = c.cell.lo[a] - 0.2f * ext + 1.4f * ext * u(rng);
    }
    const bool flat = u(rng) < 0.3f;
    const int flat_axis = int(u(rng) * 3) % 3;
    Bounds tb;
    for (auto& v : t) {
      Float3 p;
      for (int a = 0; a < 3; ++a) p[a] = (flat && a == flat_axis) ? centre[a] : centre[a] + (u(rng) - 0.5f) * 0.6f;
      v = d3(p);
      tb.extend(p);
    }
    mark_occupancy(c.cell, tb, c.block.occupancy);
    c.block.geometry.extend(tb.lo);  // the block's geometry bounds, as the partitioner keeps them
    c.block.geometry.extend(tb.hi);
    c.tris.push_back(t);
  }
  return c;
}

}  // namespace

TEST(EmptySpace, NeverSkipsASegmentThatHitsATriangle) {
  std::mt19937 rng(20261201);
  std::uniform_real_distribution<float> u(0, 1);
  int skipped = 0, aimed = 0, total = 0;
  for (int it = 0; it < 400; ++it) {
    const Case c = make_case(rng);
    for (int r = 0; r < 200; ++r) {
      Float3 o, target;
      for (int a = 0; a < 3; ++a) {
        const float ext = c.cell.hi[a] - c.cell.lo[a];
        o[a] = c.cell.lo[a] - ext + 3 * ext * u(rng);
        target[a] = c.cell.lo[a] + ext * u(rng);
      }
      // Half the rays aim at a point of a triangle (they must never be skipped where they hit).
      if (r % 2 == 0) {
        const auto& t = c.tris[std::size_t(u(rng) * float(c.tris.size())) % c.tris.size()];
        double b1 = u(rng), b2 = u(rng);
        if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
        for (int a = 0; a < 3; ++a) target[a] = float(t[0][a] + b1 * (t[1][a] - t[0][a]) + b2 * (t[2][a] - t[0][a]));
        ++aimed;
      }
      Float3 d;
      double len = 0;
      for (int a = 0; a < 3; ++a) d[a] = target[a] - o[a], len += double(d[a]) * d[a];
      if (len < 1e-12) continue;
      len = std::sqrt(len);
      for (int a = 0; a < 3; ++a) d[a] = float(d[a] / len);
      if (r % 7 == 0) d[r % 3] = 0;  // rays parallel to a face
      // The segment: the ray clipped to the cell (as enter_cell gives), in parts.
      float t0 = 0, t1 = 1e30f;
      bool meets = true;
      for (int a = 0; a < 3; ++a) {
        if (d[a] == 0) {
          if (o[a] < c.cell.lo[a] || o[a] > c.cell.hi[a]) meets = false;
          continue;
        }
        float ta = (c.cell.lo[a] - o[a]) / d[a], tb = (c.cell.hi[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta), t1 = std::min(t1, tb);
      }
      if (!meets || !(t0 < t1)) continue;
      if (r % 3 == 1) t1 = t0 + (t1 - t0) * u(rng);  // a ray ending inside (a shadow ray)
      ++total;
      if (segment_may_hit(c.block, o, d, t0, t1)) continue;
      ++skipped;
      for (const auto& t : c.tris) {
        const double th = hit_t(d3(o), d3(d), t);
        if (std::isnan(th)) continue;
        const double slack = 1e-5 * (std::fabs(t0) + std::fabs(t1) + 1);
        ASSERT_FALSE(th >= t0 - slack && th <= t1 + slack)
            << "skipped a segment [" << t0 << ", " << t1 << "] that hits a triangle at t = " << th;
      }
    }
  }
  std::printf("empty-space skipping: %d of %d segments skipped (%d aimed at a triangle)\n", skipped, total, aimed);
  EXPECT_GT(skipped, total / 20) << "the grids must skip some empty space";
}

TEST(EmptySpace, NoGridOrFullGridNeverSkips) {
  BlockInfo b;
  b.cell.lo = {0, 0, 0};
  b.cell.hi = {1, 1, 1};
  const Float3 o{-1, 0.5f, 0.5f}, d{1, 0, 0};
  EXPECT_TRUE(segment_may_hit(b, o, d, 1, 2)) << "a block without a grid (older partitions)";
  b.has_occupancy = true;
  mark_occupancy(b.cell, b.cell, b.occupancy);
  EXPECT_TRUE(segment_may_hit(b, o, d, 1, 2));
  BlockInfo e;  // a grid with no voxel set: an empty block
  e.cell = b.cell;
  e.has_occupancy = true;
  EXPECT_FALSE(segment_may_hit(e, o, d, 1, 2));
}

TEST(EmptySpace, CornerTriangleMarksItsVoxelAndItsNeighbours) {
  BlockInfo b;
  b.cell.lo = {0, 0, 0};
  b.cell.hi = {2, 2, 2};
  Bounds tb;  // inside the corner voxel (2 / kOccupancyRes wide)
  tb.extend(Float3{0.01f, 0.01f, 0.01f});
  tb.extend(Float3{0.02f, 0.02f, 0.02f});
  b.has_occupancy = true;
  mark_occupancy(b.cell, tb, b.occupancy);
  int set = 0;
  for (auto w : b.occupancy) set += std::popcount(w);
  EXPECT_EQ(set, 8) << "grown by one voxel, clamped to the grid: 2x2x2 at the corner";
  // A ray along the far edge of the cell misses those voxels; one through the corner does not.
  EXPECT_FALSE(segment_may_hit(b, Float3{-1, 1.9f, 1.9f}, Float3{1, 0, 0}, 1, 3));
  EXPECT_TRUE(segment_may_hit(b, Float3{-1, 0.05f, 0.05f}, Float3{1, 0, 0}, 1, 3));
}

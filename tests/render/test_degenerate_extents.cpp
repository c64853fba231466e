// Degenerate scene extents: every place that divides by an extent (occupancy-grid scales,
// the cell walk's slab test, camera framing, the partitioner's bounds) stays finite on
// flat, ulp-thin and point-like scenes, and refuses extents that overflow the float range.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <random>
#include <filesystem>
#include <limits>

#include "common/error.hpp"
#include "render/integrator/cell_walk.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"

namespace fs = std::filesystem;
using rayline::InputError;
using rayline::partition::BlockIndex;
using rayline::partition::BlockInfo;
using rayline::partition::Bounds;
using rayline::partition::mark_occupancy;
using rayline::scene::Float3;
using rayline::scene::Triangle;

namespace {

constexpr int R = BlockInfo::kOccupancyRes;

bool bit(const BlockInfo::Occupancy& o, int x, int y, int z) {
  const int b = x + R * (y + R * z);
  return (o[std::size_t(b / 64)] >> (b % 64)) & 1;
}

Bounds box(Float3 lo, Float3 hi) {
  Bounds b;
  b.lo = lo, b.hi = hi;
  return b;
}

// A one-leaf index over `bounds`.
BlockIndex single_cell(const Bounds& bounds) {
  BlockIndex idx;
  idx.bounds = bounds;
  idx.nodes.resize(1);
  idx.nodes[0].cell = bounds;
  idx.blocks.resize(1);
  idx.blocks[0].cell = bounds;
  return idx;
}

}  // namespace

// The occupancy scale R / 1e-40 overflows: the axis is one column, every voxel along it set,
// and no NaN reaches an int cast (the crash this guards against indexed a bit with INT_MIN).
TEST(DegenerateExtents, OccupancyOfAThinCellCoversTheThinAxis) {
  for (float thin : {1e-40f, 1e-45f, 0.0f}) {
    BlockInfo b;
    b.cell = box({0, 0, 0}, {1, thin, 1});
    mark_occupancy(b.cell, box({0, 0, 0}, {0.01f, thin, 0.01f}), b.occupancy);
    for (int y = 0; y < R; ++y) EXPECT_TRUE(bit(b.occupancy, 0, y, 0)) << thin << " y=" << y;
    EXPECT_FALSE(bit(b.occupancy, R - 1, 0, R - 1)) << thin;  // the resolved axes still resolve
    b.has_occupancy = true;
    EXPECT_TRUE(rayline::trace::segment_may_hit(b, {0.5f, 1, 0.5f}, {0, -1, 0}, 0, 2)) << thin;
  }
}

// A ray with a NaN direction (a degenerate camera) is answered, not cast to a voxel index.
TEST(DegenerateExtents, SegmentTestSurvivesNonFiniteRays) {
  BlockInfo b;
  b.cell = box({0, 0, 0}, {1, 1, 1});
  b.has_occupancy = true;
  mark_occupancy(b.cell, b.cell, b.occupancy);  // every voxel set: any segment in the cell may hit
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(rayline::trace::segment_may_hit(b, {0.5f, 0.5f, 0.5f}, {nan, nan, nan}, 0, 1));
  EXPECT_TRUE(rayline::trace::segment_may_hit(b, {0.5f, 0.5f, 0.5f}, {1e-38f, 1e-38f, 1}, 0, 1e30f));
}

// A flat root (or one thinner than an ulp of the ray's t) is met at one point: the ray
// still enters its cell, over its whole interval, so a flat scene is visible.
TEST(DegenerateExtents, RaysEnterAFlatRoot) {
  for (float thin : {0.0f, 1e-40f}) {
    const BlockIndex idx = single_cell(box({0, 0, 0}, {1, thin, 1}));
    rayline::trace::CellSpan span;
    ASSERT_TRUE(rayline::trace::enter_cell(idx, {0.5f, 3, 0.5f}, {0, -1, 0}, 0, 100, span)) << thin;
    EXPECT_EQ(span.cell, 0u);
    EXPECT_EQ(span.tenter, 0.0f);
    EXPECT_EQ(span.texit, 100.0f);
    // Beside the scene, or stopping short of it: no cell.
    EXPECT_FALSE(rayline::trace::enter_cell(idx, {2, 3, 0.5f}, {0, -1, 0}, 0, 100, span)) << thin;
    EXPECT_FALSE(rayline::trace::enter_cell(idx, {0.5f, 3, 0.5f}, {0, -1, 0}, 0, 2, span)) << thin;
  }
}

TEST(DegenerateExtents, PartitionRefusesBoundsBeyondTheFloatRange) {
  const fs::path out = fs::temp_directory_path() / ("rayline-degenerate-" + std::to_string(::getpid()));
  const Triangle t{{-3e38f, 0, 0}, {3e38f, 0, 0}, {0, 3e38f, 1}, 0};
  auto source = [&](const rayline::scene::TriangleBatchFn& fn) {
    fn(std::span<const Triangle>(&t, 1));
    return rayline::scene::ImportStats{};
  };
  rayline::partition::PartitionOptions opt;
  opt.blocks = 4;
  try {
    rayline::partition::partition_triangles(source, "huge", out.string(), opt);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("float range"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(out));
}

TEST(DegenerateExtents, FramingRefusesBoundsItCannotPlaceACameraOn) {
  EXPECT_THROW(rayline::scene::frame_mesh("huge.obj", box({-3e38f, 0, 0}, {3e38f, 3e38f, 1})), InputError);
  EXPECT_NO_THROW(rayline::scene::frame_mesh("point.obj", box({0, 0, 0}, {1e-40f, 1e-40f, 1e-41f})));
  EXPECT_NO_THROW(rayline::scene::frame_mesh("flat.obj", box({0, 0, 0}, {1, 0, 1})));
}

namespace {
// The slab clip of a one-leaf index as enter_cell documents it (cell_walk.hpp), written out
// here as the reference for its shortcut.
bool reference_one_cell(const BlockIndex& idx, Float3 o, Float3 d, float tmin, float tmax, rayline::trace::CellSpan& out) {
  float lo = tmin, hi = tmax;
  bool thin = false;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < idx.bounds.lo[a] || o[a] > idx.bounds.hi[a]) return false;
      continue;
    }
    float t0 = (idx.bounds.lo[a] - o[a]) / d[a], t1 = (idx.bounds.hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    thin = thin || t0 == t1;
    lo = std::max(lo, t0), hi = std::min(hi, t1);
  }
  if (!(lo < hi || (thin && lo == hi))) return false;
  out.cell = idx.nodes[0].block;
  out.tenter = tmin;  // the root leaf's interval reaches the ray's own ends
  out.texit = tmax;
  return true;
}
}  // namespace

// enter_cell skips the slab clip for a fresh ray from strictly inside a one-cell scene; its
// answer is the clip's to the bit, for origins inside, on the faces and outside, any
// direction (axis-parallel ones included), tmin 0, -0 or later, any tmax.
TEST(CellWalk, OneCellShortcutIsTheSlabClip) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int scene = 0; scene < 50; ++scene) {
    const Float3 lo{u(rng) * 10, u(rng) * 10, u(rng) * 10};
    const Float3 hi{lo.x + 1 + 5 * std::fabs(u(rng)), lo.y + 1e-3f + std::fabs(u(rng)), lo.z + 2};
    const BlockIndex idx = single_cell(box(lo, hi));
    int inside = 0;
    for (int k = 0; k < 2000; ++k) {
      Float3 o, d{u(rng), u(rng), u(rng)};
      for (int a = 0; a < 3; ++a) {
        const float f = u(rng) * 0.7f + 0.5f;  // [-0.2, 1.2]: inside, and outside the box
        o[a] = lo[a] + f * (hi[a] - lo[a]);
        if (k % 7 == a) o[a] = (k % 2) ? lo[a] : hi[a];  // on a face
        if (k % 11 == a) d[a] = 0;                         // parallel to a slab
      }
      inside += lo.x < o.x && o.x < hi.x && lo.y < o.y && o.y < hi.y && lo.z < o.z && o.z < hi.z;
      const float tmin = k % 5 == 0 ? -0.0f : (k % 5 == 1 ? std::fabs(u(rng)) * 3 : 0.0f);
      const float tmax = k % 3 == 0 ? std::numeric_limits<float>::infinity() : std::fabs(u(rng)) * 4;
      rayline::trace::CellSpan got, want;
      const bool g = rayline::trace::enter_cell(idx, o, d, tmin, tmax, got);
      const bool w = reference_one_cell(idx, o, d, tmin, tmax, want);
      ASSERT_EQ(g, w) << "scene " << scene << " ray " << k;
      if (!g) continue;
      EXPECT_EQ(got.cell, want.cell);
      EXPECT_EQ(std::bit_cast<std::uint32_t>(got.tenter), std::bit_cast<std::uint32_t>(want.tenter)) << k;
      EXPECT_EQ(std::bit_cast<std::uint32_t>(got.texit), std::bit_cast<std::uint32_t>(want.texit)) << k;
    }
    EXPECT_GT(inside, 300) << "the shortcut must be exercised";
  }
}

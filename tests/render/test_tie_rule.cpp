// The closest-hit tie rule the CPU path shares with the GPU kernel (render/embree/tie_break.hpp):
// of triangles met at exactly the same t, the smaller prim wins, whatever order Embree's
// traversal meets them in. Duplicated triangles (identical vertices, so identical t) are
// scattered among other triangles so the BVH puts them in different leaves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <vector>

#include "render/embree/block_geometry.hpp"
#include "render/embree/tie_break.hpp"

using namespace rayline::trace;

namespace {

void put(std::vector<unsigned char>& rec, std::size_t i, const float v[9]) { std::memcpy(&rec[i * 40], v, 36); }

}  // namespace

TEST(TieRule, SmallerPrimWinsAmongTrianglesAtTheSameDistance) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  for (int trial = 0; trial < 20; ++trial) {
    const std::size_t n = 4000;
    std::vector<unsigned char> rec(n * 40, 0);
    // Background: small triangles far behind the tie plane (z in [5, 10]).
    for (std::size_t i = 0; i < n; ++i) {
      const float x = u(rng), y = u(rng), z = 7.5f + u(rng) / 4;
      const float v[9] = {x, y, z, x + 0.1f, y, z, x, y + 0.1f, z};
      put(rec, i, v);
    }
    // Eight copies of one triangle at z = 1, at random prims.
    std::vector<std::size_t> slots(n);
    for (std::size_t i = 0; i < n; ++i) slots[i] = i;
    std::shuffle(slots.begin(), slots.end(), rng);
    slots.resize(8);
    const float tri[9] = {-1, -1, 1, 3, -1, 1, -1, 3, 1};
    for (std::size_t s : slots) put(rec, s, tri);
    const std::size_t smallest = *std::min_element(slots.begin(), slots.end());
    for (BvhQuality q : {BvhQuality::Low, BvhQuality::Medium, BvhQuality::High}) {
      EmbreeDevice dev(1);
      BlockGeometry block(dev, 0, rec, n, q);
      TieBreakContext tie;
      rtcInitIntersectContext(&tie.ctx);
      for (int k = 0; k < 16; ++k) {
        RTCRayHit rh{};
        rh.ray.org_x = -0.5f + 0.1f * float(k % 4), rh.ray.org_y = -0.5f + 0.1f * float(k / 4), rh.ray.org_z = 0;
        rh.ray.dir_x = 0, rh.ray.dir_y = 0, rh.ray.dir_z = 1;
        rh.ray.tnear = 0, rh.ray.tfar = 1e30f, rh.ray.mask = ~0u;
        rh.hit.geomID = rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
        tie.reset();
        rtcIntersect1(static_cast<RTCScene>(block.scene()), &tie.ctx, &rh);
        ASSERT_EQ(rh.hit.primID, smallest) << "trial " << trial << " quality " << int(q) << " ray " << k;
        EXPECT_EQ(rh.ray.tfar, 1.0f);
      }
    }
  }
}

// Camera rays go to Embree 8 at a time (embree_kernels.cpp, rtcIntersect8): the filter keeps
// one tie state per lane, so every lane of a packet obeys the same rule, and a packet finds
// the same triangle as its rays one at a time — on duplicated triangles (exact ties) and on
// a soup of random ones crossed by neighbouring rays (edges shared by nothing, near misses).
TEST(TieRule, PacketsOfEightFindTheHitsOfSingleRays) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  const std::size_t n = 3000;
  std::vector<unsigned char> rec(n * 40, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const float x = u(rng), y = u(rng), z = 5.0f + u(rng) / 2;
    const float v[9] = {x, y, z, x + 1.5f, y + u(rng) / 20, z + u(rng) / 20, x, y + 1.5f, z};
    put(rec, i, v);
  }
  std::vector<std::size_t> slots(n);
  for (std::size_t i = 0; i < n; ++i) slots[i] = i;
  std::shuffle(slots.begin(), slots.end(), rng);
  slots.resize(6);
  const float tri[9] = {-1, -1, -1, 3, -1, -1, -1, 3, -1};  // six copies at z = -1: every ray towards -z ties there
  for (std::size_t s : slots) put(rec, s, tri);
  const std::size_t smallest = *std::min_element(slots.begin(), slots.end());
  for (BvhQuality q : {BvhQuality::Low, BvhQuality::Medium}) {
    EmbreeDevice dev(1);
    BlockGeometry block(dev, 0, rec, n, q);
    const auto scene = static_cast<RTCScene>(block.scene());
    TieBreakContext one, eight;
    rtcInitIntersectContext(&one.ctx);
    rtcInitIntersectContext(&eight.ctx);
    eight.ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    std::uniform_real_distribution<float> jitter(-0.02f, 0.02f);
    int hits = 0, ties = 0;
    for (int packet = 0; packet < 400; ++packet) {
      const bool down = packet % 4 == 0;  // towards the duplicates
      const float ox = down ? 0 : u(rng), oy = down ? 0 : u(rng);
      alignas(32) RTCRayHit8 rh8{};
      alignas(32) int valid[8];
      RTCRayHit single[8];
      for (int i = 0; i < 8; ++i) {
        valid[i] = i < 7 || packet % 3 ? -1 : 0;  // some packets with an idle lane
        RTCRayHit& s = single[i];
        s = RTCRayHit{};
        s.ray.org_x = ox + jitter(rng) * 10, s.ray.org_y = oy + jitter(rng) * 10, s.ray.org_z = 0;
        s.ray.dir_x = jitter(rng), s.ray.dir_y = jitter(rng), s.ray.dir_z = down ? -1.0f : 1.0f;
        s.ray.tnear = 0, s.ray.tfar = 1e30f, s.ray.mask = ~0u;
        s.hit.geomID = s.hit.primID = RTC_INVALID_GEOMETRY_ID;
        rh8.ray.org_x[i] = s.ray.org_x, rh8.ray.org_y[i] = s.ray.org_y, rh8.ray.org_z[i] = s.ray.org_z;
        rh8.ray.dir_x[i] = s.ray.dir_x, rh8.ray.dir_y[i] = s.ray.dir_y, rh8.ray.dir_z[i] = s.ray.dir_z;
        rh8.ray.tnear[i] = 0, rh8.ray.tfar[i] = 1e30f, rh8.ray.mask[i] = ~0u;
        rh8.hit.geomID[i] = rh8.hit.primID[i] = RTC_INVALID_GEOMETRY_ID;
        one.reset();
        rtcIntersect1(scene, &one.ctx, &s);
      }
      eight.reset(8);
      rtcIntersect8(valid, scene, &eight.ctx, &rh8);
      for (int i = 0; i < 8; ++i) {
        if (!valid[i]) continue;
        ASSERT_EQ(rh8.hit.primID[i], single[i].hit.primID) << "quality " << int(q) << " packet " << packet << " lane " << i;
        if (single[i].hit.primID != RTC_INVALID_GEOMETRY_ID) {
          ++hits;
          EXPECT_EQ(rh8.ray.tfar[i], single[i].ray.tfar);
        }
        if (down && single[i].hit.primID == smallest) ++ties;
      }
    }
    EXPECT_GT(hits, 1000) << "the soup must be hit often for the comparison to mean something";
    EXPECT_GT(ties, 500) << "rays towards the duplicates must meet them";
  }
}

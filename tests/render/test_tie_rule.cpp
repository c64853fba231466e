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

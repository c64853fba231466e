// Furnace test: inside a closed diffuse sphere of albedo a and uniform emission
// E, with max_depth = D surface hits, every pixel converges to L = E·Σ_{i<D} a^i (Russian
// roulette keeps the estimator unbiased). Statistic: the image mean (pixels are i.i.d.
// estimates) must lie within 4 standard errors of L, the standard error estimated from the
// spread of the pixel values; and no pixel may be far off (8 of its own standard errors).
#include <gtest/gtest.h>

#include <cmath>

#include "render/engine/renderer.hpp"

using rayline::engine::render;
using rayline::engine::RenderOptions;

namespace {

void furnace(int max_depth, std::uint32_t blocks, rayline::Bytes budget_divisor) {
  RenderOptions o;
  o.scene = std::string(RAYLINE_SCENES_DIR) + "/furnace.json";  // a = 0.5, E = 0.5
  o.width = 32;
  o.height = 32;
  o.spp = 16;
  o.max_depth = max_depth;
  o.threads = 2;
  o.blocks = blocks;
  o.batching.min_batch = 512;
  o.keep_schedule_outputs = false;
  if (budget_divisor > 0) {
    RenderOptions probe = o;
    probe.width = probe.height = 4;
    probe.spp = 1;
    o.memory_budget = render(probe).scene_block_bytes / budget_divisor;
  }
  const auto r = render(o);
  double expect = 0;
  for (int i = 0; i < max_depth; ++i) expect += 0.5 * std::pow(0.5, i);
  const std::size_t n = std::size_t(r.width) * std::size_t(r.height);
  double sum = 0, sum2 = 0;
  for (std::size_t p = 0; p < n; ++p) {
    const double v = r.rgb[p * 3 + 1];
    sum += v, sum2 += v * v;
  }
  const double mean = sum / double(n), var = std::max(0.0, sum2 / double(n) - mean * mean);
  const double se = std::sqrt(var / double(n));
  EXPECT_NEAR(mean, expect, 4 * se + 1e-6) << "depth " << max_depth << " blocks " << blocks << " se " << se;
  const double pixel_sd = std::sqrt(var);
  for (std::size_t p = 0; p < n; ++p) ASSERT_NEAR(r.rgb[p * 3 + 1], expect, 8 * pixel_sd + 1e-6) << "pixel " << p;
  EXPECT_EQ(r.counts.created, r.counts.ended());
  if (max_depth <= 2) {
    EXPECT_LT(se, 1e-6) << "without roulette every path sees exactly E at each hit";
  }
}

}  // namespace

TEST(RenderFurnace, OneBounceIsExact) { furnace(1, 4, 0); }
TEST(RenderFurnace, TwoBouncesAreExact) { furnace(2, 4, 0); }
TEST(RenderFurnace, FiveBouncesWithRoulette) { furnace(5, 8, 0); }
TEST(RenderFurnace, TwelveBouncesOutOfCore) { furnace(12, 16, 3); }

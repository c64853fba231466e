// The batching renderer against an independent reference (acceptance): the plain
// in-core Embree path tracer of render/reference (own random numbers, one BVH, no cells,
// no batching) renders the same scene; the two must agree within Monte Carlo noise.
// Statistic: for every 8x8 tile and colour channel, z = (ours - reference) / SE, where SE
// of the difference of the two tile means is sqrt(2)·(reference's pooled per-pixel
// variance / (64·spp))^(1/2) — both estimators have the same variance. Thresholds: every
// |z| < 5, at most 2 % of |z| > 3 (Gaussian: 0.27 %), and the image mean per channel within
// 4 SE. Run in core and at a 25 % memory budget with 16 blocks.
#include <gtest/gtest.h>

#include <cmath>

#include "render/engine/renderer.hpp"
#include "render/reference/reference.hpp"
#include "render/scene/scene.hpp"

using namespace rayline;

namespace {

void compare(engine::RenderOptions o) {
  const scene::Scene sc = scene::default_scene();
  o.width = 48;
  o.height = 48;
  o.spp = 64;
  o.threads = 2;
  o.seed = 11;
  o.keep_schedule_outputs = false;
  const engine::RenderResult ours = engine::render(o);
  reference::ReferenceOptions ro;
  ro.width = o.width;
  ro.height = o.height;
  ro.spp = o.spp;
  ro.max_depth = sc.render.max_depth;
  ro.seed = 99;
  const reference::ReferenceImage ref = reference::render_reference(sc, ro);
  ASSERT_EQ(ours.max_depth, ref.max_depth);
  const int T = 8, tiles_x = o.width / T, tiles_y = o.height / T;
  int over3 = 0, total = 0;
  double worst = 0;
  for (int c = 0; c < 3; ++c) {
    double sum_o = 0, sum_r = 0, var_sum = 0;
    for (int ty = 0; ty < tiles_y; ++ty)
      for (int tx = 0; tx < tiles_x; ++tx) {
        double to = 0, tr = 0, tv = 0;
        for (int y = ty * T; y < (ty + 1) * T; ++y)
          for (int x = tx * T; x < (tx + 1) * T; ++x) {
            const std::size_t i = ref.index(x, y, c);
            to += ours.rgb[i], tr += ref.rgb[i], tv += ref.variance[i];
          }
        sum_o += to, sum_r += tr, var_sum += tv;
        const double n = T * T;
        const double se = std::sqrt(2 * (tv / n) / (n * o.spp));
        if (se <= 0) continue;  // a tile no light reaches: both must be 0
        const double z = (to / n - tr / n) / se;
        worst = std::max(worst, std::fabs(z));
        over3 += std::fabs(z) > 3;
        ++total;
      }
    const double n = double(o.width) * o.height;
    const double se = std::sqrt(2 * (var_sum / n) / (n * o.spp));
    EXPECT_NEAR(sum_o / n, sum_r / n, 4 * se) << "channel " << c;
  }
  EXPECT_LT(worst, 5.0);
  EXPECT_LE(over3, std::max(1, total / 50)) << over3 << " of " << total << " tile-channels beyond 3 SE";
  EXPECT_EQ(ours.counts.created, ours.counts.ended());
}

}  // namespace

TEST(RenderVsReference, CornellInCore) {
  engine::RenderOptions o;
  o.blocks = 4;
  compare(o);
}

TEST(RenderVsReference, CornellQuarterBudgetSixteenBlocks) {
  engine::RenderOptions o;
  o.blocks = 16;
  engine::RenderOptions probe = o;
  probe.width = probe.height = 4;
  probe.spp = 1;
  probe.bvh_quality = "low";
  o.memory_budget = engine::render(probe).scene_block_bytes / 4;
  compare(o);
}

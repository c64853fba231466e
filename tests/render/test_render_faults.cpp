// Faults in the renderer (docs/faults.md): a compute device's thread lost mid-render, and
// a block read failing, leave the image bit for bit the one of the fault-free render (the
// aborted work is planned again on what is left; random numbers are keyed by pixel,
// sample and bounce, and the film accumulates in fixed point).
#include <gtest/gtest.h>

#include "common/error.hpp"
#include "render/engine/renderer.hpp"
#include "small_render.hpp"

using rayline::engine::render;
using rayline::engine::RenderOptions;
using rayline::engine::RenderResult;

namespace {

RenderOptions base() {
  RenderOptions o = rayline::testing::small_render(40, 40, 4, 7, 2048);
  o.threads = 3;
  return o;
}

void expect_whole(const RenderResult& r) {
  EXPECT_EQ(r.counts.created, r.counts.ended()) << "rays created must equal rays ended";
  for (std::uint32_t s : r.samples) ASSERT_EQ(s, std::uint32_t(r.spp)) << "every pixel gets exactly spp samples";
  EXPECT_EQ(r.store.unplanned_loads, 0u) << "a block was used before its planned load";
}

}  // namespace

TEST(RenderFaults, LaneLostMidRenderSameImage) {
  const RenderResult clean = render(base());
  expect_whole(clean);
  // W.cpu0 at 0 s: the fault lands between the first plan and its dispatch, so the first
  // plan's work there (ties go to the first device) is always planned again. W.cpu1 later:
  // mid-render, with or without planned work there at that moment (timing).
  for (const char* fault : {"W.cpu0@0s", "W.cpu1@10ms", "W.cpu1@40ms"}) {
    RenderOptions o = base();
    o.memory_budget = clean.scene_block_bytes / 4;
    o.faults = {fault};
    const RenderResult r = render(o);
    expect_whole(r);
    EXPECT_EQ(clean.sums, r.sums) << fault;
    if (std::string(fault) == "W.cpu0@0s") {
      EXPECT_EQ(r.run.faults, 1);
      EXPECT_GT(r.run.requeued, 0u) << "the first plan's E-job on W.cpu0 must be planned again";
    }
  }
}

TEST(RenderFaults, BlockReadFailingMidRenderIsRetriedSameImage) {
  const RenderResult clean = render(base());
  RenderOptions o = base();
  o.memory_budget = clean.scene_block_bytes / 4;
  o.fail_read = 3;
  const RenderResult r = render(o);
  expect_whole(r);
  EXPECT_EQ(r.run.retried, 1u);
  EXPECT_EQ(clean.sums, r.sums);
}

TEST(RenderFaults, MemoryDevicesCannotBeLost) {
  RenderOptions o = base();
  o.faults = {"W.ram@1s"};
  EXPECT_THROW(render(o), rayline::InputError);
}

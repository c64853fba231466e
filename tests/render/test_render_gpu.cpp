// Issue 7 acceptance, on whatever Vulkan device exists (lavapipe in CI): the image is the
// same bit for bit with the GPU on and off, in core and out of core; a GPU that runs out of
// memory or is lost mid-render costs no sample; a GPU asked for by name must exist.
#include <gtest/gtest.h>

#include "render/engine/renderer.hpp"
#include "small_render.hpp"
#include "render/gpu/vulkan_device.hpp"
#include "sched/error.hpp"

using rayline::engine::render;
using rayline::engine::RenderOptions;
using rayline::engine::RenderResult;

namespace {

// lavapipe when present (CI), else the first device; "" when there is no Vulkan device.
std::string test_gpu() {
  const auto devs = rayline::gpu::list_gpu_devices();
  for (const auto& d : devs)
    if (d.cpu_backed) return std::to_string(d.index);
  return devs.empty() ? "" : std::to_string(devs.front().index);
}

RenderOptions base(const std::string& gpu) { return rayline::testing::small_render(32, 32, 4, 11, 2048, gpu); }

void expect_complete(const RenderResult& r) {
  EXPECT_EQ(r.counts.created, r.counts.ended()) << "rays created must equal rays ended";
  for (std::uint32_t s : r.samples) ASSERT_EQ(s, std::uint32_t(r.spp)) << "every pixel gets exactly spp samples";
  EXPECT_EQ(r.film_dropped, 0u);
}

#define REQUIRE_GPU(sel)                                                      \
  const std::string sel = test_gpu();                                         \
  if (sel.empty()) GTEST_SKIP() << "no Vulkan device on this machine";

}  // namespace

TEST(RenderGpu, SameImageWithGpuOnAndOff) {
  REQUIRE_GPU(gpu);
  const RenderResult off = render(base("none"));
  const RenderResult on = render(base(gpu));
  expect_complete(off);
  expect_complete(on);
  EXPECT_EQ(on.gpu_status, "used");
  EXPECT_GT(on.gpu.gpu_rays, 0u) << "the plan never used the GPU";
  EXPECT_GT(on.gpu.block_uploads, 0u);
  EXPECT_EQ(on.gpu.fallback_rays, 0u);
  EXPECT_EQ(off.sums, on.sums) << "GPU on and off must give the same image bit for bit";
  EXPECT_EQ(off.counts.created, on.counts.created);
}

TEST(RenderGpu, SameImageOutOfCoreWithSmallGpuMemory) {
  REQUIRE_GPU(gpu);
  RenderOptions a = base("none");
  const RenderResult off = render(a);
  RenderOptions b = base(gpu);
  b.memory_budget = off.scene_block_bytes / 2;
  // 40 % of the scene (plus one ray queue): blocks must be evicted from the GPU too.
  b.batching.max_batch = 1024;
  b.gpu_memory_budget = off.scene_block_bytes * 2 / 5 + std::uint64_t(b.batching.max_batch) * 64;
  const RenderResult on = render(b);
  expect_complete(on);
  EXPECT_GT(on.gpu.gpu_rays, 0u);
  EXPECT_GT(on.gpu.block_evictions, 0u) << "40 % of the scene in GPU memory must force evictions";
  EXPECT_EQ(off.sums, on.sums);
}

TEST(RenderGpu, LostDeviceMidRenderLosesNoSample) {
  REQUIRE_GPU(gpu);
  const RenderResult off = render(base("none"));
  RenderOptions o = base(gpu);
  o.gpu_fault_after = 6;  // a few uploads and dispatches succeed first
  o.gpu_fault = "lost";
  const RenderResult r = render(o);
  expect_complete(r);
  EXPECT_EQ(r.gpu_status.rfind("lost: ", 0), 0u) << r.gpu_status;
  EXPECT_EQ(off.sums, r.sums) << "the CPU path must finish the GPU's work exactly";
}

TEST(RenderGpu, OutOfGpuMemoryLosesNoSample) {
  REQUIRE_GPU(gpu);
  const RenderResult off = render(base("none"));
  RenderOptions o = base(gpu);
  o.gpu_fault_after = 1;  // the first upload fails
  o.gpu_fault = "oom";
  const RenderResult r = render(o);
  expect_complete(r);
  EXPECT_GE(r.gpu.upload_failures, 1u);
  EXPECT_NE(r.gpu_status.find("failures"), std::string::npos) << r.gpu_status;
  EXPECT_EQ(off.sums, r.sums);
}

TEST(RenderGpu, NamedGpuMustExist) {
  RenderOptions o = base("no-such-gpu-anywhere");
  try {
    render(o);
    FAIL() << "a missing --gpu device must be an error";
  } catch (const rayline::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-gpu-anywhere"), std::string::npos) << e.what();
  }
}

TEST(RenderGpu, AutoSkipsCpuBackedDevices) {
  const auto devs = rayline::gpu::list_gpu_devices();
  bool real = false;
  for (const auto& d : devs) real = real || !d.cpu_backed;
  RenderOptions o = base("auto");
  const RenderResult r = render(o);
  expect_complete(r);
  if (real) {
    EXPECT_EQ(r.gpu_status, "used");
    EXPECT_FALSE(r.gpu_cpu_backed);
  } else {
    EXPECT_EQ(r.gpu_status.rfind("none", 0), 0u) << r.gpu_status;
    EXPECT_TRUE(r.gpu_device.empty());
  }
}

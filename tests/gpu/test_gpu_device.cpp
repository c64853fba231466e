// The Vulkan device layer: listing and selection, errors and their kinds, fault
// injection (DeviceLost poisons the context), memory accounting, and uploads concurrent
// with dispatches from two threads giving the same hits.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <optional>
#include <thread>

#include "gpu_test_util.hpp"
#include "tests/gpu/ray_workloads.hpp"

using namespace rayline;
using namespace rayline::gpu;
using namespace rayline::gpu::testing;

namespace {

scene::Bounds unit_box() {
  scene::Bounds b;
  b.lo = {-0.1f, -0.1f, -0.1f};
  b.hi = {1.1f, 1.1f, 1.1f};
  return b;
}

template <typename F>
GpuErrorKind error_kind(F&& f, std::string* what = nullptr) {
  try {
    f();
  } catch (const GpuError& e) {
    if (what) *what = e.what();
    return e.kind();
  }
  ADD_FAILURE() << "no GpuError thrown";
  return GpuErrorKind::Failed;
}

std::vector<GpuHit> closest(GpuContext& ctx, const GpuBlock& b, const GpuRays& q) {
  std::vector<GpuHit> h(q.size());
  intersect_closest(ctx, b, q, h);
  return h;
}

bool same(const std::vector<GpuHit>& a, const std::vector<GpuHit>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(GpuHit)) == 0;
}

}  // namespace

TEST(GpuDevice, ListsLlvmpipeAsCpuBacked) {
  std::string why;
  const auto devices = list_gpu_devices(&why);
  if (devices.empty()) GTEST_SKIP() << "no Vulkan device: " << why;
  bool llvmpipe = false;
  for (const auto& d : devices) {
    std::printf("device %d: %s [%s] api %s, driver %s, %llu MiB device-local\n", d.index, d.name.c_str(),
                d.type.c_str(), d.api_version.c_str(), d.driver.c_str(),
                static_cast<unsigned long long>(d.device_local_bytes >> 20));
    EXPECT_FALSE(d.name.empty());
    EXPECT_FALSE(d.api_version.empty());
    EXPECT_GT(d.device_local_bytes, 0u);
    if (d.name.find("llvmpipe") != std::string::npos) {
      llvmpipe = true;
      EXPECT_TRUE(d.cpu_backed);
      EXPECT_EQ(d.type, "cpu");
      EXPECT_NE(d.driver.find("llvmpipe"), std::string::npos) << d.driver;
    }
  }
  if (!llvmpipe) std::printf("(no lavapipe here: the CPU-backed checks did not run)\n");
  RL_GPU_CONTEXT(ctx);
  EXPECT_EQ(ctx->info().name, devices[static_cast<std::size_t>(ctx->info().index)].name);
  EXPECT_FALSE(ctx->lost());
  EXPECT_EQ(ctx->allocated_bytes(), 0u);
}

TEST(GpuDevice, SelectorsThatMatchNothingThrowNotFound) {
  std::string why;
  const auto devices = list_gpu_devices(&why);
  if (devices.empty()) GTEST_SKIP() << "no Vulkan device: " << why;
  std::string msg;
  EXPECT_EQ(error_kind([] { GpuContext::open("no-such-gpu"); }, &msg), GpuErrorKind::NotFound);
  EXPECT_NE(msg.find("no-such-gpu"), std::string::npos) << msg;
  EXPECT_NE(msg.find(devices[0].name), std::string::npos) << "the message lists the devices: " << msg;
  EXPECT_EQ(error_kind([] { GpuContext::open("97"); }), GpuErrorKind::NotFound);
  bool only_cpu = true;
  for (const auto& d : devices) only_cpu = only_cpu && d.cpu_backed;
  if (only_cpu) {
    EXPECT_EQ(error_kind([] { GpuContext::open("auto"); }, &msg), GpuErrorKind::NotFound);
    EXPECT_NE(msg.find("CPU"), std::string::npos) << msg;
  }
  // By index and case-insensitive name.
  auto by_index = GpuContext::open("0");
  EXPECT_EQ(by_index->info().index, 0);
  std::string upper = devices[0].name.substr(0, 4);
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  EXPECT_EQ(GpuContext::open(upper)->info().name, devices[0].name);
}

TEST(GpuDevice, InjectedFaultsHaveTheirKind) {
  RL_GPU_CONTEXT(ctx);
  const auto rec = soup_records(500, 1);
  const auto rays = random_rays(unit_box(), 256, 2);
  for (GpuErrorKind k : {GpuErrorKind::OutOfMemory, GpuErrorKind::Failed}) {
    ctx->inject_fault(1, k);
    EXPECT_EQ(error_kind([&] { upload_rays(*ctx, rays); }), k);
    EXPECT_FALSE(ctx->lost());
    EXPECT_NO_THROW(upload_rays(*ctx, rays));  // one-shot
  }
  // The third operation from now: block upload, ray upload, then the dispatch fails.
  ctx->inject_fault(3, GpuErrorKind::OutOfMemory);
  auto block = upload_block(*ctx, rec, 500);
  auto q = upload_rays(*ctx, rays);
  std::vector<GpuHit> hits(rays.size());
  EXPECT_EQ(error_kind([&] { intersect_closest(*ctx, *block, *q, hits); }), GpuErrorKind::OutOfMemory);
  const auto before = closest(*ctx, *block, *q);  // works again
  ctx->inject_fault(0, GpuErrorKind::Failed);      // disarmed
  EXPECT_NO_THROW(upload_block(*ctx, rec, 500));
  EXPECT_EQ(ctx->allocated_bytes(), block->device_bytes() + q->device_bytes());
}

TEST(GpuDevice, DeviceLostPoisonsTheContext) {
  RL_GPU_CONTEXT(ctx);
  const auto rec = soup_records(500, 1);
  const auto rays = random_rays(unit_box(), 256, 2);
  auto block = upload_block(*ctx, rec, 500);
  auto q = upload_rays(*ctx, rays);
  std::vector<GpuHit> hits(rays.size());
  std::vector<std::uint8_t> any(rays.size());
  ctx->inject_fault(1, GpuErrorKind::DeviceLost);
  std::string msg;
  EXPECT_EQ(error_kind([&] { intersect_any(*ctx, *block, *q, any); }, &msg), GpuErrorKind::DeviceLost);
  EXPECT_TRUE(ctx->lost());
  // Every later call throws DeviceLost.
  EXPECT_EQ(error_kind([&] { intersect_closest(*ctx, *block, *q, hits); }, &msg), GpuErrorKind::DeviceLost);
  EXPECT_NE(msg.find("lost"), std::string::npos) << msg;
  EXPECT_EQ(error_kind([&] { upload_rays(*ctx, rays); }), GpuErrorKind::DeviceLost);
  EXPECT_EQ(error_kind([&] { upload_block(*ctx, rec, 500); }), GpuErrorKind::DeviceLost);
  // What was resident is still freed cleanly.
  block.reset();
  q.reset();
  EXPECT_EQ(ctx->allocated_bytes(), 0u);
}

// A block whose triangles do not fit the device's storage binding (lavapipe: 128 MiB,
// 2.8 M triangles) is OutOfMemory, before any BVH is built.
TEST(GpuDevice, BlockLargerThanTheDeviceIsOutOfMemory) {
  RL_GPU_CONTEXT(ctx);
  const std::uint64_t n = 3'000'000;
  if (!ctx->info().cpu_backed) GTEST_SKIP() << "a real GPU binds " << n << " triangles";
  std::vector<unsigned char> rec(n * 40);
  std::string msg;
  EXPECT_EQ(error_kind([&] { upload_block(*ctx, rec, n); }, &msg), GpuErrorKind::OutOfMemory);
  EXPECT_NE(msg.find("maxStorageBufferRange"), std::string::npos) << msg;
  EXPECT_EQ(ctx->allocated_bytes(), 0u);
  EXPECT_FALSE(ctx->lost());
}

TEST(GpuDevice, AccountingAndArguments) {
  RL_GPU_CONTEXT(ctx);
  const auto rec = soup_records(2000, 3);
  const auto rays = random_rays(unit_box(), 1000, 4);
  {
    auto block = upload_block(*ctx, rec, 2000);
    EXPECT_EQ(block->triangles(), 2000u);
    EXPECT_EQ(block->device_bytes(), block->bvh_nodes * 64 + block->leaf_triangles * 48);
    EXPECT_GT(block->build_seconds, 0.0);
    EXPECT_EQ(ctx->allocated_bytes(), block->device_bytes());
    auto q = upload_rays(*ctx, rays);
    EXPECT_EQ(q->size(), rays.size());
    EXPECT_EQ(q->device_bytes(), rays.size() * sizeof(GpuRay));
    EXPECT_EQ(ctx->allocated_bytes(), block->device_bytes() + q->device_bytes());
    std::vector<GpuHit> hits(rays.size());
    GpuDispatchStats st;
    const double s = intersect_closest(*ctx, *block, *q, hits, &st);
    EXPECT_GT(s, 0.0);
    EXPECT_EQ(s, st.kernel_seconds);
    EXPECT_EQ(st.download_bytes, rays.size() * sizeof(GpuHit));
    EXPECT_GT(ctx->scratch_bytes(), 0u);
    // Wrong output size, records too short, rays of another context.
    std::vector<GpuHit> small(rays.size() - 1);
    EXPECT_THROW(intersect_closest(*ctx, *block, *q, small), std::invalid_argument);
    EXPECT_THROW(upload_block(*ctx, std::span<const unsigned char>(rec).first(100), 2000), std::invalid_argument);
    auto other = GpuContext::open(std::to_string(ctx->info().index));
    auto foreign = upload_rays(*other, rays);
    EXPECT_THROW(intersect_closest(*ctx, *block, *foreign, hits), std::invalid_argument);
    // An empty ray queue.
    auto none = upload_rays(*ctx, {});
    std::vector<GpuHit> no_hits;
    EXPECT_EQ(intersect_closest(*ctx, *block, *none, no_hits), 0.0);
  }
  EXPECT_EQ(ctx->allocated_bytes(), 0u);
  // A block may outlive its context: the device stays alive until the last one goes.
  auto block = upload_block(*ctx, rec, 2000);
  ctx.reset();
  block.reset();
}

// The RAM->GPU channel's thread uploads blocks while the GPU compute thread dispatches:
// every dispatch gives exactly the hits of the same dispatch run alone.
TEST(GpuDevice, ConcurrentUploadsAndDispatches) {
  RL_GPU_CONTEXT(ctx);
  const auto rec_a = soup_records(20000, 5, 0.05f);
  const auto rec_b = soup_records(20000, 6, 0.05f);
  const auto rays = random_rays(unit_box(), 20000, 7);
  auto block_a = upload_block(*ctx, rec_a, 20000);
  auto q = upload_rays(*ctx, rays);
  const auto ref_a = closest(*ctx, *block_a, *q);
  std::vector<GpuHit> ref_b;
  {
    auto block_b = upload_block(*ctx, rec_b, 20000);
    ref_b = closest(*ctx, *block_b, *q);
  }
  std::atomic<int> bad{0}, done_a{0}, done_b{0};
  std::thread uploader([&] {  // uploads (and uses) block B again and again, with its own rays
    for (int i = 0; i < 4; ++i) {
      auto block_b = upload_block(*ctx, rec_b, 20000);
      auto qb = upload_rays(*ctx, rays);
      bad += !same(closest(*ctx, *block_b, *qb), ref_b);
      ++done_b;
    }
  });
  std::thread dispatcher([&] {
    for (int i = 0; i < 8; ++i) {
      bad += !same(closest(*ctx, *block_a, *q), ref_a);
      std::vector<std::uint8_t> any(rays.size());
      intersect_any(*ctx, *block_a, *q, any);
      for (std::size_t k = 0; k < rays.size(); ++k) bad += (any[k] != 0) != (ref_a[k].prim != kNoHit);
      ++done_a;
    }
  });
  uploader.join();
  dispatcher.join();
  EXPECT_EQ(bad.load(), 0);
  EXPECT_EQ(done_a.load(), 8);
  EXPECT_EQ(done_b.load(), 4);
  EXPECT_EQ(ctx->allocated_bytes(), block_a->device_bytes() + q->device_bytes());
}

// The discrete-GPU path (device-local data reached through staging copies, results copied
// back to a host buffer) gives the same hits as direct mapping; RAYLINE_GPU_STAGING=1
// forces it on lavapipe. Uploads larger than the 64 MiB staging buffer go in chunks.
TEST(GpuDevice, StagingPathMatchesDirectMapping) {
  RL_GPU_CONTEXT(ctx);
  const char* was = std::getenv("RAYLINE_GPU_STAGING");
  const std::optional<std::string> saved = was ? std::optional<std::string>(was) : std::nullopt;
  ::setenv("RAYLINE_GPU_STAGING", "1", 1);
  auto staged = GpuContext::open(std::to_string(ctx->info().index));
  if (saved)
    ::setenv("RAYLINE_GPU_STAGING", saved->c_str(), 1);
  else
    ::unsetenv("RAYLINE_GPU_STAGING");
  EXPECT_TRUE(staged->uses_staging());
  const auto rec = soup_records(20000, 8, 0.05f);
  const auto rays = random_rays(unit_box(), 20000, 9);
  std::vector<std::vector<GpuHit>> hits;
  std::vector<std::vector<std::uint8_t>> any;
  for (GpuContext* c : {ctx.get(), staged.get()}) {
    auto block = upload_block(*c, rec, 20000);
    auto q = upload_rays(*c, rays);
    hits.push_back(closest(*c, *block, *q));
    any.emplace_back(rays.size());
    intersect_any(*c, *block, *q, any.back());
  }
  EXPECT_TRUE(same(hits[0], hits[1]));
  EXPECT_EQ(any[0], any[1]);
  // 2.5 M rays (80 MB: two staging chunks) against one big triangle.
  const float tri[9] = {-10, -10, 0, 10, -10, 0, 0, 10, 0};
  std::vector<unsigned char> one(40, 0);
  std::memcpy(one.data(), tri, 36);
  std::vector<GpuRay> many(2'500'000);
  for (std::size_t i = 0; i < many.size(); ++i)
    many[i] = make_ray({float(i % 2000) * 1e-3f - 1.0f, float(i / 2000) * 1e-3f - 0.5f, 1.0f}, {0, 0, -1});
  auto block = upload_block(*staged, one, 1);
  auto q = upload_rays(*staged, many);
  std::vector<std::uint8_t> occ(many.size());
  intersect_any(*staged, *block, *q, occ);
  std::size_t hit = 0;
  for (auto o : occ) hit += o;
  EXPECT_EQ(hit, many.size());
  EXPECT_GT(staged->scratch_bytes(), 0u);
  staged->release_scratch();
  EXPECT_EQ(staged->scratch_bytes(), 0u);
}

// No driver (the loader pointed at a missing ICD manifest): an empty list with the reason,
// and NoVulkan from open(); the loader rescans at every instance, so the real list returns.
TEST(GpuDevice, NoDriverIsNoVulkan) {
  std::string before_why;
  const std::size_t before = list_gpu_devices(&before_why).size();
  std::vector<std::pair<const char*, std::optional<std::string>>> saved;
  for (const char* var : {"VK_DRIVER_FILES", "VK_ICD_FILENAMES"}) {
    const char* v = std::getenv(var);
    saved.emplace_back(var, v ? std::optional<std::string>(v) : std::nullopt);
    ::setenv(var, "/nonexistent/rayline_icd.json", 1);
  }
  std::string why, msg;
  const auto none = list_gpu_devices(&why);
  const GpuErrorKind k = error_kind([] { GpuContext::open("auto"); }, &msg);
  for (const auto& [var, v] : saved) {
    if (v)
      ::setenv(var, v->c_str(), 1);
    else
      ::unsetenv(var);
  }
  EXPECT_TRUE(none.empty());
  EXPECT_FALSE(why.empty());
  EXPECT_EQ(k, GpuErrorKind::NoVulkan);
  EXPECT_NE(msg.find("vkCreateInstance"), std::string::npos) << msg;
  EXPECT_EQ(list_gpu_devices().size(), before);
}

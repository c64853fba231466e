#include "render/embree/block_geometry.hpp"

#include "render/embree/array_pool.hpp"
#include "render/embree/tie_break.hpp"

#include <embree3/rtcore.h>

#include <atomic>
#include <bit>
#include <cstring>
#include <stdexcept>
#include <string>

namespace rayline::trace {

static_assert(std::endian::native == std::endian::little, "block records are little-endian and copied as is");

struct EmbreeDevice::Counter {
  std::atomic<std::int64_t> bytes{0}, peak{0};
};

namespace {
bool monitor(void* user, ssize_t bytes, bool /*post*/) {
  auto* c = static_cast<EmbreeDevice::Counter*>(user);
  const std::int64_t now = c->bytes.fetch_add(bytes) + bytes;
  std::int64_t p = c->peak.load();
  while (now > p && !c->peak.compare_exchange_weak(p, now)) {
  }
  return true;
}
}  // namespace

EmbreeDevice::EmbreeDevice(int build_threads) : counter_(std::make_unique<Counter>()) {
  const std::string cfg = "threads=" + std::to_string(build_threads < 1 ? 1 : build_threads) + ",set_affinity=0";
  RTCDevice d = rtcNewDevice(cfg.c_str());
  if (!d) throw std::runtime_error("Embree: rtcNewDevice failed (error " + std::to_string(rtcGetDeviceError(nullptr)) + ")");
  rtcSetDeviceMemoryMonitorFunction(d, monitor, counter_.get());
  device_ = d;
}

EmbreeDevice::~EmbreeDevice() { rtcReleaseDevice(static_cast<RTCDevice>(device_)); }
std::int64_t EmbreeDevice::embree_bytes() const { return counter_->bytes.load(); }
std::int64_t EmbreeDevice::peak_embree_bytes() const { return counter_->peak.load(); }

BlockGeometry::BlockGeometry(const EmbreeDevice& device, std::uint32_t block, std::span<const unsigned char> records,
                             std::uint64_t n, BvhQuality quality, ArrayPool* pool)
    : block_(block), pool_(pool) {
  if (records.size() < n * 40) throw std::logic_error("block payload shorter than its triangles");
  if (pool) {  // recycled arrays: their pages are already mapped (array_pool.hpp)
    vertices_ = pool->floats(n * 9 + 3);
    indices_ = pool->uints(n * 3);
    materials_ = pool->uints(n);
  } else {
    vertices_.resize(n * 9 + 3);  // Embree reads 16 bytes at the last float3: pad
    indices_.resize(n * 3);
    materials_.resize(n);
  }
  vertices_[n * 9] = vertices_[n * 9 + 1] = vertices_[n * 9 + 2] = 0;
  for (std::uint64_t i = 0; i < n; ++i) {
    const unsigned char* r = records.data() + i * 40;
    std::memcpy(&vertices_[i * 9], r, 36);  // little-endian host (static_assert above)
    std::memcpy(&materials_[i], r + 36, 4);
    const auto base = static_cast<std::uint32_t>(i * 3);
    indices_[i * 3] = base, indices_[i * 3 + 1] = base + 1, indices_[i * 3 + 2] = base + 2;
  }
  if (n == 0) return;
  auto dev = static_cast<RTCDevice>(device.handle());
  RTCScene sc = rtcNewScene(dev);
  // Low quality: Embree's fast low-quality builder, about 3-4x faster to build than medium;
  // blocks loaded again and again out of core pay the build each time. The scene stays a
  // *static* one (no RTC_SCENE_FLAG_DYNAMIC, which also selects a quick builder): Embree
  // allocates a static BVH differently (likely its OS-level block allocator rather than
  // malloc; not verified in its source). Measured on the 10 M-triangle museum at a 25 %
  // budget, two runs each: 289-357 k page faults and 597-844 MB peak RSS static, against
  // 377-562 k and 889-962 MB dynamic, for the same CPU time (a 4 KiB page fault costs
  // ≈ 17 µs on the development VM).
  // Robust mode (conservative box test, watertight Plücker triangle test) for every quality:
  // the fast mode's box test can drop a flat leaf box (axis-aligned floors and walls) for a
  // ray that meets it, and which box it drops depends on the BVH built. On a scene of two
  // coplanar, differently tessellated floors, 1 460 of 20 000 camera rays hit a different
  // triangle with the SAH and the Morton BVH in fast mode, none in robust mode; the image
  // then differed between in core and out of core (RenderDeterminism.
  // BvhQualitySameImageOnZFighting). Cost: not measurable in core, ≈ 3 % at a 25 % budget.
  const bool low = quality == BvhQuality::Low;
  rtcSetSceneFlags(sc, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(sc, low ? RTC_BUILD_QUALITY_LOW : (quality == BvhQuality::High ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM));
  RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices_.data(), 0, 12, n * 3);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices_.data(), 0, 12, n);
  if (low) rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_LOW);
  rtcSetGeometryIntersectFilterFunction(g, smaller_prim_wins_ties);  // tie_break.hpp
  rtcCommitGeometry(g);
  rtcAttachGeometry(sc, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(sc);
  if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) {
    rtcReleaseScene(sc);
    throw std::runtime_error("Embree: building the BVH of block " + std::to_string(block) + " failed");
  }
  scene_ = sc;
}

BlockGeometry::~BlockGeometry() {
  if (scene_) rtcReleaseScene(static_cast<RTCScene>(scene_));
  if (pool_) {
    pool_->give(std::move(vertices_));
    pool_->give(std::move(indices_));
    pool_->give(std::move(materials_));
  }
}

std::uint64_t BlockGeometry::array_bytes() const {
  return vertices_.capacity() * sizeof(float) + indices_.capacity() * 4 + materials_.capacity() * 4;
}

std::vector<unsigned char> BlockGeometry::records() const {
  std::vector<unsigned char> out(materials_.size() * 40);
  for (std::size_t i = 0; i < materials_.size(); ++i) {
    std::memcpy(&out[i * 40], &vertices_[i * 9], 36);
    std::memcpy(&out[i * 40 + 36], &materials_[i], 4);
  }
  return out;
}

void smaller_prim_wins_ties(const RTCFilterFunctionNArguments* args) {
  // Only rtcIntersect1 queries carry a TieBreakContext (path_kernels.cpp); a packet (N > 1)
  // would need per-lane state, and none is traced here.
  if (args->N != 1 || args->valid[0] != -1) return;
  auto* c = const_cast<TieBreakContext*>(reinterpret_cast<const TieBreakContext*>(args->context));
  const float t = RTCRayN_tfar(args->ray, 1, 0);  // the candidate's distance
  const unsigned prim = RTCHitN_primID(args->hit, 1, 0);
  if (t == c->best_t && prim > c->best_prim) {
    args->valid[0] = 0;  // keep the smaller prim met earlier
    return;
  }
  c->best_t = t;
  c->best_prim = prim;
}

}  // namespace rayline::trace

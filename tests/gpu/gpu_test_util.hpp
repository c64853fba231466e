// Shared by the GPU tests: opening a device (lavapipe when present), an Embree 3 reference
// set up like trace::BlockGeometry (triangle geometry, shared buffers, medium quality), and
// the hit-by-hit comparison: every ray the kernels call certain gets Embree's answer.
#pragma once
#include <embree3/rtcore.h>
#include <gtest/gtest.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "render/vulkan/gpu_kernels.hpp"
#include "render/vulkan/vulkan_device.hpp"

namespace rayline::gpu::testing {

inline constexpr double kEps = 1e-5;  // |t_gpu - t_embree| <= kEps * max(1, t)

// lavapipe ("llvmpipe") when listed, else the first device; nullptr (with the reason) when
// there is no Vulkan device at all.
inline std::unique_ptr<GpuContext> open_test_context(std::string& why) {
  const auto devices = list_gpu_devices(&why);
  if (devices.empty()) return nullptr;
  std::string selector = "0";
  for (const auto& d : devices) {
    std::string n = d.name;
    for (char& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (n.find("llvmpipe") != std::string::npos) selector = "llvmpipe";
  }
  return GpuContext::open(selector);
}

#define RL_GPU_CONTEXT(ctx)                                                 \
  std::string ctx##_why;                                                    \
  auto ctx = ::rayline::gpu::testing::open_test_context(ctx##_why);         \
  if (!ctx) GTEST_SKIP() << "no Vulkan device: " << ctx##_why;

inline void flush_denormals() {
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

// Embree's answer for the same records (the CPU renderer's BlockGeometry setup).
class EmbreeRef {
 public:
  // robust: RTC_SCENE_FLAG_ROBUST (conservative box test, watertight Plücker triangle
  // test), as the renderer's BlockGeometry sets it; false: Embree's fast mode (Möller–Trumbore).
  EmbreeRef(std::span<const unsigned char> records, std::uint64_t n, bool robust = true) {
    flush_denormals();
    device_ = rtcNewDevice("threads=1");
    vertices_.resize(n * 9 + 3);
    indices_.resize(n * 3);
    for (std::uint64_t i = 0; i < n; ++i) {
      std::memcpy(&vertices_[i * 9], records.data() + i * 40, 36);
      for (int k = 0; k < 3; ++k) indices_[i * 3 + k] = static_cast<unsigned>(i * 3 + k);
    }
    scene_ = rtcNewScene(device_);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_MEDIUM);
    if (robust) rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
    if (n) {
      RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
      rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices_.data(), 0, 12, n * 3);
      rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices_.data(), 0, 12, n);
      rtcCommitGeometry(g);
      rtcAttachGeometry(scene_, g);
      rtcReleaseGeometry(g);
    }
    rtcCommitScene(scene_);
  }
  ~EmbreeRef() {
    rtcReleaseScene(scene_);
    rtcReleaseDevice(device_);
  }
  EmbreeRef(const EmbreeRef&) = delete;
  EmbreeRef& operator=(const EmbreeRef&) = delete;

  struct Hit {
    float t = INFINITY;
    std::uint32_t prim = kNoHit;
  };
  Hit closest(const GpuRay& r) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    fill(rh.ray, r);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &ctx, &rh);
    Hit h;
    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) h.t = rh.ray.tfar, h.prim = rh.hit.primID;
    return h;
  }
  bool occluded(const GpuRay& r) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay ray{};
    fill(ray, r);
    rtcOccluded1(scene_, &ctx, &ray);
    return ray.tfar == -INFINITY;
  }

 private:
  static void fill(RTCRay& ray, const GpuRay& r) {
    ray.org_x = r.org[0], ray.org_y = r.org[1], ray.org_z = r.org[2];
    ray.dir_x = r.dir[0], ray.dir_y = r.dir[1], ray.dir_z = r.dir[2];
    ray.tnear = r.tmin, ray.tfar = r.tmax;
    ray.mask = 0xFFFFFFFFu, ray.flags = 0, ray.time = 0;
  }
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<float> vertices_;
  std::vector<unsigned> indices_;
};

// The ray's parameter at the plane of triangle `prim`, in double precision.
inline double plane_t(std::span<const unsigned char> rec, std::uint32_t prim, const GpuRay& r) {
  float v[9];
  std::memcpy(v, rec.data() + std::size_t(prim) * 40, 36);
  const double e1[3] = {double(v[3]) - v[0], double(v[4]) - v[1], double(v[5]) - v[2]};
  const double e2[3] = {double(v[6]) - v[0], double(v[7]) - v[1], double(v[8]) - v[2]};
  const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const double den = n[0] * r.dir[0] + n[1] * r.dir[1] + n[2] * r.dir[2];
  const double num = n[0] * (double(v[0]) - r.org[0]) + n[1] * (double(v[1]) - r.org[1]) + n[2] * (double(v[2]) - r.org[2]);
  return num / den;
}

inline bool close(double a, double b) { return std::fabs(a - b) <= kEps * std::max(1.0, std::fabs(b)); }

struct Agreement {
  std::size_t rays = 0, hits = 0, misses = 0, mismatches = 0, any_mismatches = 0, occluded = 0;
  // Rays the kernels flagged doubtful (closest, any hit), and those among them where the
  // kernel's own guess differs from Embree: the cracks and ties the flag keeps out.
  std::size_t doubtful = 0, any_doubtful = 0, doubtful_differ = 0, any_doubtful_differ = 0;
  std::vector<std::string> errors;  // the first few
  void error(const std::string& s) {
    if (errors.size() < 8) errors.push_back(s);
  }
  double doubtful_fraction() const { return rays ? double(doubtful + any_doubtful) / double(2 * rays) : 0.0; }
  std::string summary() const {
    std::ostringstream o;
    o << rays << " rays: " << hits << " same hits, " << misses << " misses, " << mismatches << " closest mismatches, "
      << occluded << " occluded, " << any_mismatches << " any-hit mismatches; doubtful " << doubtful << " closest ("
      << doubtful_differ << " of them with a guess other than Embree's), " << any_doubtful << " any hit ("
      << any_doubtful_differ << ")";
    for (const auto& e : errors) o << "\n  " << e;
    return o.str();
  }
};

inline std::string ray_text(const GpuRay& r) {
  std::ostringstream o;
  o.precision(9);
  o << "org (" << r.org[0] << ", " << r.org[1] << ", " << r.org[2] << ") dir (" << r.dir[0] << ", " << r.dir[1] << ", "
    << r.dir[2] << ") [" << r.tmin << ", " << r.tmax << "]";
  return o.str();
}

// GPU closest hits and any-hit answers against Embree, ray by ray. Every ray the kernel
// calls certain must get Embree's answer exactly: the same prim (no tie or crack allowance:
// those rays must be flagged doubtful), t within kEps, the same occlusion. Doubtful rays
// are counted, with how often the kernel's own guess differs from Embree.
inline void compare(std::span<const unsigned char> rec, const EmbreeRef& ref, std::span<const GpuRay> rays,
                    std::span<const GpuHit> hits, std::span<const std::uint8_t> any, Agreement& a) {
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const GpuRay& r = rays[i];
    const GpuHit& g = hits[i];
    const float gt = hit_t(g);
    const EmbreeRef::Hit e = ref.closest(r);
    ++a.rays;
    if (doubtful(g)) {
      ++a.doubtful;
      a.doubtful_differ += e.prim != g.prim;
      if (std::getenv("RL_GPU_PRINT_DOUBTFUL"))
        std::printf("doubtful ray %zu %s: gpu guess prim %d t %.9g, embree prim %d t %.9g\n", i, ray_text(r).c_str(),
                    int(g.prim), gt, int(e.prim), e.t);
    } else if (e.prim == kNoHit && g.prim == kNoHit) {
      ++a.misses;
    } else if (e.prim == g.prim) {
      float v[9];
      std::uint32_t m = 0;
      std::memcpy(v, rec.data() + std::size_t(g.prim) * 40, 36);
      std::memcpy(&m, rec.data() + std::size_t(g.prim) * 40 + 36, 4);
      if (!close(gt, e.t) || std::memcmp(v, g.v, 36) != 0 || m != g.material || !(gt >= r.tmin && gt <= r.tmax)) {
        ++a.mismatches;
        a.error("ray " + std::to_string(i) + " " + ray_text(r) + ": prim " + std::to_string(g.prim) + " t gpu " +
                std::to_string(gt) + " embree " + std::to_string(e.t) + " (or its vertices/material differ)");
      } else {
        ++a.hits;
      }
    } else {
      ++a.mismatches;
      a.error("certain ray " + std::to_string(i) + " " + ray_text(r) + ": gpu prim " +
              (g.prim == kNoHit ? std::string("miss") : std::to_string(g.prim)) + " t " + std::to_string(gt) +
              ", embree prim " + (e.prim == kNoHit ? std::string("miss") : std::to_string(e.prim)) + " t " +
              std::to_string(e.t));
    }
    if (!any.empty()) {
      const bool occ = ref.occluded(r);
      a.occluded += occ;
      if (any[i] & kAnyDoubtful) {
        ++a.any_doubtful;
        a.any_doubtful_differ += occ != ((any[i] & kAnyOccluded) != 0);
      } else if (occ != (any[i] == kAnyOccluded)) {
        ++a.any_mismatches;
        a.error("certain ray " + std::to_string(i) + " " + ray_text(r) + ": any-hit gpu " + std::to_string(any[i]) +
                " embree " + std::to_string(occ));
      }
    }
  }
}

// Uploads, runs both kernels and compares; returns the agreement.
inline Agreement run_and_compare(GpuContext& ctx, std::span<const unsigned char> rec, std::uint64_t n,
                                 std::span<const GpuRay> rays, const EmbreeRef& ref,
                                 const GpuBuildOptions& opt = GpuBuildOptions{}) {
  auto block = upload_block(ctx, rec, n, opt);
  auto q = upload_rays(ctx, rays);
  std::vector<GpuHit> hits(rays.size());
  std::vector<std::uint8_t> any(rays.size());
  intersect_closest(ctx, *block, *q, hits);
  intersect_any(ctx, *block, *q, any);
  Agreement a;
  compare(rec, ref, rays, hits, any, a);
  return a;
}

}  // namespace rayline::gpu::testing

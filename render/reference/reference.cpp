// The reference path tracer (conventions: reference.hpp). Written independently of
// render/integrator: own RNG (PCG32 streams keyed by SplitMix64), own Embree scene over the
// whole triangle soup, iterative per-sample paths, TBB over tiles.
#include "render/reference/reference.hpp"

#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "render/scene/scene_stream.hpp"
#include "common/error.hpp"

namespace rayline::reference {

using scene::Float3;

namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInf = std::numeric_limits<float>::infinity();

Float3 mul(Float3 a, Float3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
float max_component(Float3 a) { return std::max(a.x, std::max(a.y, a.z)); }
bool is_black(Float3 a) { return a.x <= 0 && a.y <= 0 && a.z <= 0; }

// ---- random numbers ------------------------------------------------------------------
// SplitMix64's finaliser (Steele, Lea & Flood 2014) hashes (seed, pixel, sample) into the
// state and stream of a PCG32 generator (O'Neill 2014, XSH-RR output). One stream per
// camera sample, consumed in path order by the one thread tracing that sample, so the
// image depends only on the seed.
std::uint64_t splitmix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

class Pcg32 {
 public:
  Pcg32(std::uint64_t seed, std::uint64_t pixel, std::uint64_t sample) {
    const std::uint64_t key = splitmix64(splitmix64(seed ^ 0x5265666572656e63ull) ^ pixel);
    const std::uint64_t init = splitmix64(key ^ (sample * 0xd1b54a32d192ed03ull));
    inc_ = (splitmix64(init + 1) << 1u) | 1u;
    state_ = 0;
    next();
    state_ += init;
    next();
  }
  std::uint32_t next() {
    const std::uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    const auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
    const auto rot = static_cast<std::uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }
  // Uniform in [0, 1): the top 24 bits, exactly representable as a float.
  float uniform() { return float(next() >> 8) * 0x1p-24f; }

 private:
  std::uint64_t state_ = 0, inc_ = 1;
};

// ---- the Embree scene --------------------------------------------------------------------
struct World {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<float> vertices;          // 3 floats per vertex, 3 vertices per triangle (+ padding)
  std::vector<std::uint32_t> indices;   // 0, 1, 2, 3, ... (Embree needs an index buffer)
  std::vector<std::uint32_t> material;  // per triangle: index into scene.materials
  std::uint64_t triangles = 0;
  float scale = 1;                      // bounds diagonal + max |coordinate|, for offsets
  std::string error;                    // first Embree error reported by the callback

  World() = default;
  World(const World&) = delete;
  World& operator=(const World&) = delete;
  ~World() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
  Float3 vertex(std::uint32_t prim, int k) const {
    const float* v = &vertices[(std::size_t(prim) * 3 + std::size_t(k)) * 3];
    return {v[0], v[1], v[2]};
  }
};

void embree_error(void* user, RTCError code, const char* message) {
  auto* w = static_cast<World*>(user);
  if (w->error.empty()) w->error = "Embree error " + std::to_string(int(code)) + ": " + (message ? message : "");
}

void check(World& w, const char* what) {
  if (!w.error.empty()) throw std::runtime_error(std::string("reference tracer: ") + what + ": " + w.error);
}

void build_world(World& w, const scene::Scene& sc) {
  scene::Bounds bounds;
  const std::size_t nmat = sc.materials.size();
  scene::stream_scene(sc, [&](std::span<const scene::Triangle> batch) {
    for (const scene::Triangle& t : batch) {
      if (t.material >= nmat)
        throw InputError(sc.source, "meshes", "triangle material " + std::to_string(t.material) + " out of range");
      for (const Float3& v : {t.v0, t.v1, t.v2}) {
        w.vertices.insert(w.vertices.end(), {v.x, v.y, v.z});
        bounds.extend(v);
      }
      w.material.push_back(t.material);
    }
  });
  w.triangles = w.material.size();
  // Embree indices are 32-bit: at most 2^32 − 1 vertices in one geometry.
  if (w.triangles * 3 >= std::uint64_t(std::numeric_limits<std::uint32_t>::max()))
    throw InputError(sc.source, "meshes", "too many triangles for the in-core reference tracer");
  w.indices.resize(w.triangles * 3);
  for (std::size_t i = 0; i < w.indices.size(); ++i) w.indices[i] = std::uint32_t(i);
  w.vertices.resize(w.vertices.size() + 4, 0.0f);  // Embree reads vertices with 16-byte loads
  if (!bounds.empty()) {
    const Float3 e = bounds.extent();
    const float far = std::max({std::fabs(bounds.lo.x), std::fabs(bounds.lo.y), std::fabs(bounds.lo.z),
                                std::fabs(bounds.hi.x), std::fabs(bounds.hi.y), std::fabs(bounds.hi.z)});
    w.scale = std::max(scene::length(e) + far, 1e-20f);
  }

  w.device = rtcNewDevice(nullptr);
  if (!w.device) throw std::runtime_error("reference tracer: rtcNewDevice failed");
  rtcSetDeviceErrorFunction(w.device, embree_error, &w);
  w.scene = rtcNewScene(w.device);
  // Robust traversal: no ray slips through a shared edge of a closed mesh (the furnace).
  rtcSetSceneFlags(w.scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(w.scene, RTC_BUILD_QUALITY_HIGH);
  if (w.triangles > 0) {
    RTCGeometry g = rtcNewGeometry(w.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, w.vertices.data(), 0,
                               3 * sizeof(float), w.triangles * 3);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, w.indices.data(), 0,
                               3 * sizeof(std::uint32_t), w.triangles);
    rtcCommitGeometry(g);
    rtcAttachGeometry(w.scene, g);
    rtcReleaseGeometry(g);
  }
  check(w, "building the geometry");
  rtcCommitScene(w.scene);
  check(w, "building the BVH");
}

// ---- tracing ---------------------------------------------------------------------------
// Orthonormal basis around a unit n (Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited").
void basis(Float3 n, Float3& b1, Float3& b2) {
  const float s = std::copysign(1.0f, n.z);
  const float a = -1.0f / (s + n.z);
  const float b = n.x * n.y * a;
  b1 = {1.0f + s * n.x * n.x * a, s * b, -s * n.x};
  b2 = {b, s + n.y * n.y * a, -n.y};
}

struct Tracer {
  const scene::Scene& sc;
  const World& w;
  int max_depth;

  // Closest hit along (o, d) with t in [0, inf): primitive id, or -1 for a miss.
  std::int64_t intersect(Float3 o, Float3 d, float& t, float& u, float& v) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray.org_x = o.x, rh.ray.org_y = o.y, rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
    rh.ray.tnear = 0;
    rh.ray.tfar = kInf;
    rh.ray.mask = 0xffffffffu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(w.scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return -1;
    t = rh.ray.tfar, u = rh.hit.u, v = rh.hit.v;
    return std::int64_t(rh.hit.primID);
  }

  bool occluded(Float3 o, Float3 d, float tfar) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r{};
    r.org_x = o.x, r.org_y = o.y, r.org_z = o.z;
    r.dir_x = d.x, r.dir_y = d.y, r.dir_z = d.z;
    r.tnear = 0;
    r.tfar = tfar;
    r.mask = 0xffffffffu;
    rtcOccluded1(w.scene, &ctx, &r);
    return r.tfar < 0;  // Embree sets tfar = -inf on a hit
  }

  // Offset of a ray origin off a surface, along the side normal n: relative to the scene's
  // size and to |p| so that it is a few hundred ulps of either.
  float epsilon(Float3 p) const {
    const float m = std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
    return 1e-5f * (w.scale + m) * 0.5f;
  }

  // One path of camera sample (o, d); returns its radiance estimate.
  Float3 radiance(Float3 o, Float3 d, Pcg32& rng) const {
    Float3 L{0, 0, 0}, T{1, 1, 1};
    const auto& lights = sc.area_lights;
    for (int hit = 1;; ++hit) {
      float t = 0, bu = 0, bv = 0;
      const std::int64_t prim = intersect(o, d, t, bu, bv);
      if (prim < 0) {  // leaves the scene: constant environment
        L = L + mul(T, sc.environment.radiance);
        break;
      }
      const auto id = std::uint32_t(prim);
      const Float3 v0 = w.vertex(id, 0), v1 = w.vertex(id, 1), v2 = w.vertex(id, 2);
      // Embree's barycentrics: p = (1 − u − v)·v0 + u·v1 + v·v2 (more exact than o + t·d).
      const Float3 p = v0 + (v1 - v0) * bu + (v2 - v0) * bv;
      Float3 n = scene::normalize(cross(v1 - v0, v2 - v0));
      if (dot(n, d) > 0) n = n * -1.0f;  // two-sided: face the incoming ray
      const scene::Material& m = sc.materials[w.material[id]];
      L = L + mul(T, m.emission);  // emission, both sides, every hit
      const Float3 po = p + n * epsilon(p);

      // Next-event estimation: one light uniformly, one point uniformly on it.
      if (!lights.empty() && !is_black(m.albedo)) {
        const float ul = rng.uniform(), us = rng.uniform(), ut = rng.uniform();
        const std::size_t li = std::min(std::size_t(ul * float(lights.size())), lights.size() - 1);
        const scene::AreaLight& A = lights[li];
        const Float3 q = A.corner + A.edge_u * us + A.edge_v * ut;
        const Float3 ln = cross(A.edge_u, A.edge_v);
        const float area = scene::length(ln);
        const Float3 to = q - po;
        const float dist2 = dot(to, to);
        if (area > 0 && dist2 > 0) {
          const float dist = std::sqrt(dist2);
          const Float3 wi = to * (1.0f / dist);
          const float cos_s = std::max(0.0f, dot(n, wi));
          const float cos_l = std::max(0.0f, -dot(ln, wi) / area);  // one-sided: cross(edge_u, edge_v)
          if (cos_s > 0 && cos_l > 0) {
            // 1 / pdf_area = numLights · area.
            const float g = cos_s * cos_l * float(lights.size()) * area / dist2;
            const Float3 c = mul(mul(T, m.albedo * (1.0f / kPi)), A.emission) * g;
            // Lights are invisible: only geometry strictly before the light point occludes.
            if (!is_black(c) && !occluded(po, wi, dist - epsilon(q))) L = L + c;
          }
        }
      }

      if (hit >= max_depth) break;
      // Continuation: cosine-weighted hemisphere, f·cos/pdf = albedo.
      T = mul(T, m.albedo);
      if (hit >= 3) {  // Russian roulette after hits 3, 4, ...
        const float q = std::min(0.95f, max_component(T));
        if (!(rng.uniform() < q)) break;
        T = T * (1.0f / q);
      }
      if (is_black(T)) break;
      const float u1 = rng.uniform(), u2 = rng.uniform();
      const float r = std::sqrt(u1), phi = 2.0f * kPi * u2;
      Float3 b1, b2;
      basis(n, b1, b2);
      d = scene::normalize(b1 * (r * std::cos(phi)) + b2 * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0f, 1 - u1)));
      o = po;
    }
    return L;
  }
};

}  // namespace

double ReferenceImage::standard_error(int x, int y, int channel) const {
  return spp > 0 ? std::sqrt(double(variance[index(x, y, channel)]) / spp) : 0.0;
}

ReferenceImage render_reference(const scene::Scene& sc, const ReferenceOptions& opt) {
  const std::string file = sc.source.empty() ? std::string("<scene>") : sc.source;
  if (opt.camera < 0 || std::size_t(opt.camera) >= sc.cameras.size())
    throw InputError(file, "cameras", "no camera " + std::to_string(opt.camera));
  const scene::Camera& cam = sc.cameras[std::size_t(opt.camera)];
  ReferenceImage img;
  img.width = opt.width > 0 ? opt.width : cam.width;
  img.height = opt.height > 0 ? opt.height : cam.height;
  img.spp = opt.spp > 0 ? opt.spp : sc.render.spp;
  img.max_depth = opt.max_depth >= 0 ? opt.max_depth : sc.render.max_depth;
  if (img.width <= 0 || img.height <= 0) throw InputError(file, "resolution", "width and height must be positive");
  if (img.spp <= 0) throw InputError(file, "spp", "must be positive");
  if (img.max_depth < 1) throw InputError(file, "max_depth", "must be at least 1 (surface hits per path)");
  if (opt.threads < 0) throw InputError(file, "threads", "must be >= 0");

  const auto t0 = std::chrono::steady_clock::now();
  World world;
  tbb::task_arena arena(opt.threads > 0 ? opt.threads : tbb::task_arena::automatic);
  arena.execute([&] { build_world(world, sc); });
  img.triangles = world.triangles;
  const auto t1 = std::chrono::steady_clock::now();

  // Pinhole camera frame (reference.hpp).
  const Float3 forward = scene::normalize(cam.look_at - cam.position);
  const Float3 right = scene::normalize(cross(forward, cam.up));
  if (scene::length(right) == 0 || scene::length(forward) == 0)
    throw InputError(file, "cameras", "camera '" + cam.name + "': look_at equals position or up is parallel to the view");
  const Float3 up = cross(right, forward);
  const float tan_half = float(std::tan(double(cam.fov_y_deg) * 3.14159265358979323846 / 360.0));
  const float aspect = float(img.width) / float(img.height);

  const std::size_t n = std::size_t(img.width) * std::size_t(img.height);
  img.rgb.assign(n * 3, 0.0f);
  img.variance.assign(n * 3, 0.0f);
  const Tracer tracer{sc, world, img.max_depth};

  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range2d<int>(0, img.height, 8, 0, img.width, 8),
                      [&](const tbb::blocked_range2d<int>& tile) {
      // Flush-to-zero / denormals-are-zero while tracing (Embree's advice); the thread's
      // previous mode is restored, since TBB workers run other code too.
      const unsigned csr = _mm_getcsr();
      _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
      _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
      for (int y = tile.rows().begin(); y < tile.rows().end(); ++y)
        for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) {
          const std::uint64_t pixel = std::uint64_t(y) * std::uint64_t(img.width) + std::uint64_t(x);
          // Welford's running mean and sum of squared deviations, per channel, in double.
          double mean[3] = {0, 0, 0}, m2[3] = {0, 0, 0};
          for (int s = 0; s < img.spp; ++s) {
            Pcg32 rng(opt.seed, pixel, std::uint64_t(s));
            const float u = rng.uniform(), v = rng.uniform();
            const float sx = (2.0f * (float(x) + u) / float(img.width) - 1.0f) * tan_half * aspect;
            const float sy = (1.0f - 2.0f * (float(y) + v) / float(img.height)) * tan_half;
            const Float3 dir = scene::normalize(forward + right * sx + up * sy);
            const Float3 L = tracer.radiance(cam.position, dir, rng);
            for (int c = 0; c < 3; ++c) {
              const double val = L[c], delta = val - mean[c];
              mean[c] += delta / double(s + 1);
              m2[c] += delta * (val - mean[c]);
            }
          }
          for (int c = 0; c < 3; ++c) {
            img.rgb[pixel * 3 + std::size_t(c)] = float(mean[c]);
            img.variance[pixel * 3 + std::size_t(c)] = img.spp > 1 ? float(m2[c] / double(img.spp - 1)) : 0.0f;
          }
        }
      _mm_setcsr(csr);
    });
  });
  img.build_seconds = std::chrono::duration<double>(t1 - t0).count();
  img.trace_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  return img;
}

}  // namespace rayline::reference

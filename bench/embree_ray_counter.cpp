// Counts the rays a program traces with Embree 3, for scripts/bench_embree.sh: loaded with
// LD_PRELOAD into Embree's `pathtracer` tutorial (which counts none), it stands in front of
// the two queries the tutorial calls, rtcIntersect1 and rtcOccluded1, counts one ray per
// call, passes the call on to libembree3, and at exit writes the count to the file named
// by RAYLINE_RAY_COUNT_FILE. One query is one ray shot and traced to its end (the tutorial
// has one BVH), the unit Rayline's `rays.created` counts. The counter is one shared atomic,
// so counted runs are slower: the script times other runs.
#include <dlfcn.h>
#include <embree3/rtcore.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>

namespace {
std::atomic<unsigned long long> g_rays{0};

template <class Fn>
Fn next(const char* name) {
  void* f = ::dlsym(RTLD_NEXT, name);
  if (!f) {
    std::fprintf(stderr, "embree_ray_counter: %s not found after this library\n", name);
    std::abort();
  }
  return reinterpret_cast<Fn>(f);
}

struct Report {
  ~Report() {
    const char* path = std::getenv("RAYLINE_RAY_COUNT_FILE");
    if (!path) return;
    if (std::FILE* f = std::fopen(path, "w")) {
      std::fprintf(f, "%llu\n", g_rays.load());
      std::fclose(f);
    }
  }
} g_report;
}  // namespace

extern "C" {
void rtcIntersect1(RTCScene scene, RTCIntersectContext* context, RTCRayHit* rayhit) {
  using Fn = void (*)(RTCScene, RTCIntersectContext*, RTCRayHit*);
  static const Fn real = next<Fn>("rtcIntersect1");
  g_rays.fetch_add(1, std::memory_order_relaxed);
  real(scene, context, rayhit);
}

void rtcOccluded1(RTCScene scene, RTCIntersectContext* context, RTCRay* ray) {
  using Fn = void (*)(RTCScene, RTCIntersectContext*, RTCRay*);
  static const Fn real = next<Fn>("rtcOccluded1");
  g_rays.fetch_add(1, std::memory_order_relaxed);
  real(scene, context, ray);
}
}

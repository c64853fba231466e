// GPU ray-intersection throughput: kernel-only rays/s of the Vulkan traversal
// kernels (render/vulkan) on one block with the rays already on the GPU, for coherent primary
// rays (a pinhole camera's rays in 8x8 tile order) and incoherent rays (random origins
// inside the scene bounds, random directions), closest hit and any hit; also the CPU BVH
// build time (Embree's builder + flattening), upload and hit-download bandwidth.
//
// Block: the "museum-like" generator (render/scene/generators.hpp: a two-storey arcaded
// atrium with displaced scan-like statues on pedestals) at --triangles, all in one block,
// seen from the generator's own camera; --scene soup uses a random triangle soup instead.
// Medians of --repeat runs after one warm-up run (lavapipe compiles shaders at the first
// dispatch). Kernel time comes from GPU timestamps where the queue has them.
#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "render/vulkan/gpu_kernels.hpp"
#include "tests/gpu/ray_workloads.hpp"
#include "render/vulkan/vulkan_device.hpp"
#include "render/scene/generators.hpp"
#include "render/scene/mesh_sink.hpp"

using namespace rayline;
using namespace rayline::gpu;

namespace {

struct Options {
  std::uint64_t triangles = 1'000'000;
  std::uint64_t rays = 1u << 20;
  std::string device = "auto";
  int repeat = 5;
  std::string json;
  std::string scene = "museum";
  std::string quality = "medium";
  int build_threads = 0;
  bool embree = false;
};

void usage(FILE* f) {
  std::fprintf(f,
               "bench_gpu_trace: kernel-only rays/s of the Vulkan traversal kernels on one block\n"
               "usage: bench_gpu_trace [options]\n"
               "  --triangles N      block size (default 1000000)\n"
               "  --rays N           rays per batch (default 1048576; primary rays: a square image\n"
               "                     of about N pixels, a multiple of 8 on each side)\n"
               "  --device SEL       'auto' (default: the first GPU, else lavapipe), an index, or a\n"
               "                     name substring such as 'llvmpipe' or 'H100'\n"
               "  --repeat R         timed runs per measurement, median reported (default 5)\n"
               "  --json OUT         also write the results as JSON to OUT\n"
               "  --scene S          museum (default: the museum-like generator) or soup (random)\n"
               "  --quality Q        BVH build: low, medium (default) or high\n"
               "  --build-threads T  Embree build threads (default 0: every core)\n"
               "  --embree           also time Embree's rtcIntersect1/rtcOccluded1 on one CPU thread\n"
               "  --help             this text\n");
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_gpu_trace: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      usage(stdout);
      std::exit(0);
    } else if (a == "--triangles") {
      o.triangles = std::stoull(next());
    } else if (a == "--rays") {
      o.rays = std::stoull(next());
    } else if (a == "--device") {
      o.device = next();
    } else if (a == "--repeat") {
      o.repeat = std::max(1, std::stoi(next()));
    } else if (a == "--json") {
      o.json = next();
    } else if (a == "--scene") {
      o.scene = next();
    } else if (a == "--quality") {
      o.quality = next();
    } else if (a == "--build-threads") {
      o.build_threads = std::stoi(next());
    } else if (a == "--embree") {
      o.embree = true;
    } else {
      std::fprintf(stderr, "bench_gpu_trace: unknown option %s\n", a.c_str());
      usage(stderr);
      return false;
    }
  }
  if (o.scene != "museum" && o.scene != "soup") {
    std::fprintf(stderr, "bench_gpu_trace: --scene must be museum or soup\n");
    return false;
  }
  if (o.quality != "low" && o.quality != "medium" && o.quality != "high") {
    std::fprintf(stderr, "bench_gpu_trace: --quality must be low, medium or high\n");
    return false;
  }
  return true;
}

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// CPU time of the whole process (every thread: Embree's builders, lavapipe's workers): on a
// busy machine it says what the work costs where wall time says how long it waited.
double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Workload {
  std::vector<unsigned char> records;
  std::uint64_t n = 0;
  scene::Bounds bounds;
  scene::Camera camera;
};

Workload make_workload(const Options& o) {
  Workload w;
  if (o.scene == "soup") {
    w.records = soup_records(o.triangles, 1, 0.5f / std::cbrt(double(o.triangles)) * 4);
    w.n = o.triangles;
    w.bounds.lo = {0, 0, 0}, w.bounds.hi = {1, 1, 1};
    w.camera.position = {0.5f, 0.5f, -1.2f}, w.camera.look_at = {0.5f, 0.5f, 0.5f}, w.camera.fov_y_deg = 45;
    return w;
  }
  w.records.reserve(o.triangles * 40);
  scene::TriangleBatcher batcher([&](std::span<const scene::Triangle> batch) {
    for (const auto& t : batch) {
      const float v[9] = {t.v0.x, t.v0.y, t.v0.z, t.v1.x, t.v1.y, t.v1.z, t.v2.x, t.v2.y, t.v2.z};
      const std::size_t at = w.records.size();
      w.records.resize(at + 40);
      std::memcpy(w.records.data() + at, v, 36);
      std::memcpy(w.records.data() + at + 36, &t.material, 4);
      w.bounds.extend(t.v0), w.bounds.extend(t.v1), w.bounds.extend(t.v2);
    }
  });
  scene::run_generator("museum-like", o.triangles, 1, batcher);
  batcher.flush();
  w.n = w.records.size() / 40;
  scene::Scene s;
  scene::find_generator("museum-like")->describe(s, w.bounds);
  if (!s.cameras.empty()) w.camera = s.cameras[0];
  return w;
}

struct Result {
  std::string rays, kind;
  std::uint64_t count = 0;
  double kernel_s = 0, rays_per_s = 0, hit_fraction = 0, download_gbps = 0;
  double doubtful_fraction = 0;  // rays the kernel flagged doubtful (a render hands them to Embree)
  double rays_per_cpu_s = 0;  // rays per CPU-second of the whole process (lavapipe: its workers)
  bool timestamps = false;
  double embree_rays_per_s = 0;
};

// Embree 3 on one thread over the same records (a reference point: lavapipe is a CPU).
struct EmbreeScene {
  RTCDevice dev = nullptr;
  RTCScene scene = nullptr;
  std::vector<float> v;
  std::vector<unsigned> idx;
  double build_seconds = 0;  // rtcCommitScene (Embree's own BVH8, medium quality)
  EmbreeScene(const Workload& w) {
    dev = rtcNewDevice("threads=0");
    v.resize(w.n * 9 + 3);
    idx.resize(w.n * 3);
    for (std::uint64_t i = 0; i < w.n; ++i) {
      std::memcpy(&v[i * 9], w.records.data() + i * 40, 36);
      for (int k = 0; k < 3; ++k) idx[i * 3 + k] = unsigned(i * 3 + k);
    }
    scene = rtcNewScene(dev);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, v.data(), 0, 12, w.n * 3);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, idx.data(), 0, 12, w.n);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    const auto t0 = Clock::now();
    rtcCommitScene(scene);
    build_seconds = since(t0);
  }
  ~EmbreeScene() {
    rtcReleaseScene(scene);
    rtcReleaseDevice(dev);
  }
  double rays_per_s(const std::vector<GpuRay>& rays, bool any) const {
    const auto t0 = Clock::now();
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (const GpuRay& r : rays) {
      RTCRayHit rh{};
      rh.ray.org_x = r.org[0], rh.ray.org_y = r.org[1], rh.ray.org_z = r.org[2];
      rh.ray.dir_x = r.dir[0], rh.ray.dir_y = r.dir[1], rh.ray.dir_z = r.dir[2];
      rh.ray.tnear = r.tmin, rh.ray.tfar = r.tmax, rh.ray.mask = 0xFFFFFFFFu;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      if (any)
        rtcOccluded1(scene, &ctx, &rh.ray);
      else
        rtcIntersect1(scene, &ctx, &rh);
    }
    return double(rays.size()) / since(t0);
  }
};

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) return 2;
  std::unique_ptr<GpuContext> ctx;
  try {
    try {
      ctx = GpuContext::open(o.device);
    } catch (const GpuError& e) {
      if (o.device != "auto" || e.kind() != GpuErrorKind::NotFound) throw;
      std::fprintf(stderr, "bench_gpu_trace: %s; falling back to llvmpipe\n", e.what());
      ctx = GpuContext::open("llvmpipe");
    }
  } catch (const GpuError& e) {
    std::fprintf(stderr, "bench_gpu_trace: %s\n", e.what());
    return 1;
  }
  const GpuDeviceInfo& dev = ctx->info();
  std::printf("device: %s [%s], Vulkan %s, driver %s\n", dev.name.c_str(), dev.type.c_str(), dev.api_version.c_str(),
              dev.driver.c_str());

  auto tg = Clock::now();
  const Workload w = make_workload(o);
  std::printf("block: %s, %llu triangles (generated in %.2f s)\n",
              o.scene == "museum" ? "museum-like generator" : "random soup", static_cast<unsigned long long>(w.n),
              since(tg));

  GpuBuildOptions bo;
  bo.quality = o.quality == "low" ? GpuBvhQuality::Low : (o.quality == "high" ? GpuBvhQuality::High : GpuBvhQuality::Medium);
  bo.threads = o.build_threads;
  std::vector<double> builds, uploads, build_cpu;
  std::unique_ptr<GpuBlock> block;
  const int build_repeat = std::min(o.repeat, 3);
  for (int i = 0; i < build_repeat; ++i) {
    block.reset();
    const double c0 = cpu_seconds();
    block = upload_block(*ctx, w.records, w.n, bo);
    build_cpu.push_back(cpu_seconds() - c0);  // build + upload
    builds.push_back(block->build_seconds);
    uploads.push_back(block->upload_seconds);
  }
  const double build_s = median(builds), upload_s = median(uploads), build_cpu_s = median(build_cpu);
  const double upload_gbps = double(block->device_bytes()) / upload_s * 1e-9;
  std::printf("BVH (%s): build %.3f s (median of %d; build + upload took %.3f CPU s), %llu nodes, %llu leaf "
              "triangles, depth %d, %.1f MiB on the device, upload %.2f GB/s\n",
              o.quality.c_str(), build_s, build_repeat, build_cpu_s, static_cast<unsigned long long>(block->bvh_nodes),
              static_cast<unsigned long long>(block->leaf_triangles), block->bvh_depth,
              double(block->device_bytes()) / (1 << 20), upload_gbps);

  // Ray sets.
  int side = std::max(8, int(std::lround(std::sqrt(double(o.rays)) / 8.0)) * 8);
  const auto primary = tiled_camera_rays(w.camera, side, side);
  const auto random = random_rays(w.bounds, o.rays, 12345);
  std::unique_ptr<EmbreeScene> emb;
  if (o.embree) {
    emb = std::make_unique<EmbreeScene>(w);
    std::printf("Embree scene (rtcCommitScene, for comparison): build %.3f s\n", emb->build_seconds);
  }

  std::vector<Result> results;
  double rays_upload_gbps = 0;
  for (int set = 0; set < 2; ++set) {
    const auto& rays = set == 0 ? primary : random;
    const auto tu = Clock::now();
    auto q = upload_rays(*ctx, rays);
    const double us = since(tu);
    rays_upload_gbps = std::max(rays_upload_gbps, double(q->device_bytes()) / us * 1e-9);
    std::vector<GpuHit> hits(rays.size());
    std::vector<std::uint8_t> occ(rays.size());
    for (int kind = 0; kind < 2; ++kind) {
      Result r;
      r.rays = set == 0 ? "primary" : "incoherent";
      r.kind = kind == 0 ? "closest" : "any";
      r.count = rays.size();
      std::vector<double> ks, dl, cpu;
      GpuDispatchStats st;
      for (int i = 0; i <= o.repeat; ++i) {  // run 0: warm-up
        const double c0 = cpu_seconds();
        if (kind == 0)
          intersect_closest(*ctx, *block, *q, hits, &st);
        else
          intersect_any(*ctx, *block, *q, occ, &st);
        if (i == 0) continue;
        cpu.push_back(cpu_seconds() - c0);
        ks.push_back(st.kernel_seconds);
        const double copy_s = st.copy_seconds + st.download_seconds;  // GPU -> host copy + into `out`
        dl.push_back(double(st.download_bytes) / copy_s * 1e-9);
      }
      r.kernel_s = median(ks);
      r.rays_per_s = double(rays.size()) / r.kernel_s;
      r.download_gbps = median(dl);
      r.rays_per_cpu_s = double(rays.size()) / median(cpu);
      r.timestamps = st.gpu_timestamps;
      std::uint64_t h = 0, doubt = 0;
      for (std::size_t i = 0; i < rays.size(); ++i) {
        h += kind == 0 ? hits[i].prim != kNoHit : (occ[i] & kAnyOccluded) != 0;
        doubt += kind == 0 ? doubtful(hits[i]) : (occ[i] & kAnyDoubtful) != 0;
      }
      r.hit_fraction = double(h) / double(rays.size());
      r.doubtful_fraction = double(doubt) / double(rays.size());
      if (emb) r.embree_rays_per_s = emb->rays_per_s(rays, kind == 1);
      results.push_back(r);
    }
  }

  std::printf("\n%-11s %-8s %10s %12s %14s %14s %8s %10s %14s%s\n", "rays", "kernel", "count", "kernel ms", "rays/s",
              "rays/CPU-s", "hits", "doubtful", "download GB/s", emb ? "   Embree 1 thread rays/s" : "");
  for (const auto& r : results) {
    std::printf("%-11s %-8s %10llu %12.3f %14.4g %14.4g %7.1f%% %9.3f%% %14.2f", r.rays.c_str(), r.kind.c_str(),
                static_cast<unsigned long long>(r.count), r.kernel_s * 1e3, r.rays_per_s, r.rays_per_cpu_s,
                100 * r.hit_fraction, 100 * r.doubtful_fraction, r.download_gbps);
    if (emb) std::printf("   %14.4g", r.embree_rays_per_s);
    std::printf("\n");
  }
  std::printf("primary rays: %dx%d pinhole image in 8x8 tiles; kernel time from %s\n", side, side,
              results[0].timestamps ? "GPU timestamps" : "host wall time (no timestamps on this queue)");
  std::printf("ray upload %.2f GB/s\n", rays_upload_gbps);

  if (!o.json.empty()) {
    FILE* f = std::fopen(o.json.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "bench_gpu_trace: cannot write %s\n", o.json.c_str());
      return 1;
    }
    std::fprintf(f, "{\n  \"device\": {\"name\": \"%s\", \"type\": \"%s\", \"api\": \"%s\", \"driver\": \"%s\"},\n",
                 dev.name.c_str(), dev.type.c_str(), dev.api_version.c_str(), dev.driver.c_str());
    std::fprintf(f, "  \"block\": {\"scene\": \"%s\", \"triangles\": %llu, \"quality\": \"%s\", \"bvh_nodes\": %llu, "
                    "\"leaf_triangles\": %llu, \"depth\": %d, \"device_bytes\": %llu},\n",
                 o.scene.c_str(), static_cast<unsigned long long>(w.n), o.quality.c_str(),
                 static_cast<unsigned long long>(block->bvh_nodes),
                 static_cast<unsigned long long>(block->leaf_triangles), block->bvh_depth,
                 static_cast<unsigned long long>(block->device_bytes()));
    std::fprintf(f, "  \"build_seconds\": %.6f,\n  \"build_and_upload_cpu_seconds\": %.6f,\n"
                    "  \"block_upload_gbps\": %.4f,\n  \"ray_upload_gbps\": %.4f,\n",
                 build_s, build_cpu_s, upload_gbps, rays_upload_gbps);
    if (emb) std::fprintf(f, "  \"embree_scene_build_seconds\": %.6f,\n", emb->build_seconds);
    std::fprintf(f, "  \"repeat\": %d,\n  \"primary_image\": [%d, %d],\n  \"results\": [\n", o.repeat, side, side);
    for (std::size_t i = 0; i < results.size(); ++i) {
      const auto& r = results[i];
      std::fprintf(f, "    {\"rays\": \"%s\", \"kernel\": \"%s\", \"count\": %llu, \"kernel_seconds\": %.6g, "
                      "\"rays_per_second\": %.6g, \"rays_per_cpu_second\": %.6g, \"hit_fraction\": %.6f, "
                      "\"doubtful_fraction\": %.6f, \"download_gbps\": %.4f, \"gpu_timestamps\": %s%s}%s\n",
                   r.rays.c_str(), r.kind.c_str(), static_cast<unsigned long long>(r.count), r.kernel_s, r.rays_per_s,
                   r.rays_per_cpu_s,
                   r.hit_fraction, r.doubtful_fraction, r.download_gbps, r.timestamps ? "true" : "false",
                   emb ? (", \"embree_one_thread_rays_per_second\": " + std::to_string(r.embree_rays_per_s)).c_str() : "",
                   i + 1 < results.size() ? "," : "");
    }
    std::fprintf(f, "  ]\n}\n");
    std::fclose(f);
    std::printf("wrote %s\n", o.json.c_str());
  }
  return 0;
}

// Ray sets and synthetic blocks for the GPU tests and bench/bench_gpu_trace (header-only).
//  * tiled_camera_rays: coherent primary rays, one per pixel centre of a pinhole camera, in
//    8x8 tiles (the batching renderer's tile order), so a 64-wide workgroup is one tile.
//  * random_rays: incoherent rays, origins uniform in a box, directions uniform on the
//    sphere.
//  * soup_records: a random triangle soup as block-file records (block_file.hpp layout).
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "render/vulkan/gpu_kernels.hpp"
#include "render/scene/geometry.hpp"
#include "render/scene/scene.hpp"

namespace rayline::gpu {

inline GpuRay make_ray(scene::Float3 o, scene::Float3 d, float tmin = 0.0f, float tmax = INFINITY) {
  return GpuRay{{o.x, o.y, o.z}, tmin, {d.x, d.y, d.z}, tmax};
}

inline std::vector<GpuRay> tiled_camera_rays(const scene::Camera& cam, int width, int height) {
  using scene::cross;
  using scene::normalize;
  const scene::Float3 f = normalize(cam.look_at - cam.position);
  const scene::Float3 r = normalize(cross(f, cam.up));
  const scene::Float3 u = cross(r, f);
  const float th = std::tan(cam.fov_y_deg * 0.5f * 3.14159265358979f / 180.0f);
  const float aspect = float(width) / float(height);
  std::vector<GpuRay> rays;
  rays.reserve(std::size_t(width) * std::size_t(height));
  for (int ty = 0; ty < height; ty += 8)
    for (int tx = 0; tx < width; tx += 8)
      for (int y = ty; y < std::min(ty + 8, height); ++y)
        for (int x = tx; x < std::min(tx + 8, width); ++x) {
          const float sx = (2.0f * (float(x) + 0.5f) / float(width) - 1.0f) * th * aspect;
          const float sy = (1.0f - 2.0f * (float(y) + 0.5f) / float(height)) * th;
          rays.push_back(make_ray(cam.position, normalize(f + r * sx + u * sy)));
        }
  return rays;
}

inline scene::Float3 random_direction(std::mt19937_64& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float z = 1.0f - 2.0f * u(rng), phi = 6.28318530717958647692f * u(rng);
  const float s = std::sqrt(std::max(0.0f, 1.0f - z * z));
  return {s * std::cos(phi), s * std::sin(phi), z};
}

inline std::vector<GpuRay> random_rays(const scene::Bounds& b, std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<GpuRay> rays;
  rays.reserve(n);
  const scene::Float3 e = b.extent();
  for (std::size_t i = 0; i < n; ++i) {
    const scene::Float3 o{b.lo.x + e.x * u(rng), b.lo.y + e.y * u(rng), b.lo.z + e.z * u(rng)};
    rays.push_back(make_ray(o, random_direction(rng)));
  }
  return rays;
}

// `n` random triangles in the unit cube with edges of about `size`; material = index % 7.
inline std::vector<unsigned char> soup_records(std::size_t n, std::uint64_t seed, float size = 0.03f) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<unsigned char> rec(n * 40);
  for (std::size_t i = 0; i < n; ++i) {
    float v[9];
    const float c[3] = {u(rng), u(rng), u(rng)};
    for (int k = 0; k < 9; ++k) v[k] = c[k % 3] + size * (u(rng) - 0.5f);
    const auto m = static_cast<std::uint32_t>(i % 7);
    std::memcpy(rec.data() + i * 40, v, 36);
    std::memcpy(rec.data() + i * 40 + 36, &m, 4);
  }
  return rec;
}

}  // namespace rayline::gpu

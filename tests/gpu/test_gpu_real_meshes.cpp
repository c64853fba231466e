// Issue 7 acceptance on real scans: the GPU kernels' hits equal Embree's (same triangle,
// t within gpu_test_util's epsilon) on the Stanford bunny and dragon (fetched by
// scripts/fetch_assets.sh; the test skips with the reason when they are missing). Camera
// rays from outside and random rays inside the mesh bounds, closest and any hit.
// Two kinds of difference are inherent and counted, never hidden: ties (two triangles at
// the same t) and edge cracks. Neither Embree's default triangle test nor the kernel's is
// watertight, and they round differently (Embree uses FMA), so a ray through a shared edge
// may pass between the two triangles in one and hit one of them in the other. A crack is
// accepted only where the triangle one engine hit and the other did not is met within
// 1e-5 (in barycentric units, computed in double) of its edge; at most 1 ray in 1 000.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <vector>

#include "gpu_test_util.hpp"
#include "render/gpu/ray_workloads.hpp"
#include "render/scene/mesh_import.hpp"

namespace fs = std::filesystem;
using namespace rayline;
using namespace rayline::gpu;
using namespace rayline::gpu::testing;

namespace {

struct Mesh {
  std::vector<unsigned char> records;  // block-file records (40 B), material 0
  std::uint64_t n = 0;
  scene::Bounds bounds;
};

Mesh load(const fs::path& file) {
  Mesh m;
  const scene::ImportStats st = scene::stream_mesh_file(file.string(), scene::Affine{}, [&](std::span<const scene::Triangle> b) {
    for (const scene::Triangle& t : b) {
      unsigned char rec[40] = {};
      const float v[9] = {t.v0.x, t.v0.y, t.v0.z, t.v1.x, t.v1.y, t.v1.z, t.v2.x, t.v2.y, t.v2.z};
      std::memcpy(rec, v, 36);
      m.records.insert(m.records.end(), rec, rec + 40);
      ++m.n;
    }
  });
  m.bounds = st.bounds;
  return m;
}

// How far inside its triangle the ray meets the plane of triangle `prim`, in barycentric
// units (min of u, v, 1 - u - v; negative outside), in double precision.
double edge_distance(std::span<const unsigned char> rec, std::uint32_t prim, const GpuRay& r) {
  float f[9];
  std::memcpy(f, rec.data() + std::size_t(prim) * 40, 36);
  const double v0[3] = {f[0], f[1], f[2]}, e1[3] = {f[3] - v0[0], f[4] - v0[1], f[5] - v0[2]},
               e2[3] = {f[6] - v0[0], f[7] - v0[1], f[8] - v0[2]};
  const double d[3] = {r.dir[0], r.dir[1], r.dir[2]}, s[3] = {r.org[0] - v0[0], r.org[1] - v0[1], r.org[2] - v0[2]};
  auto cross = [](const double* a, const double* b, double* o) {
    o[0] = a[1] * b[2] - a[2] * b[1], o[1] = a[2] * b[0] - a[0] * b[2], o[2] = a[0] * b[1] - a[1] * b[0];
  };
  auto dot = [](const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  double p[3], q[3];
  cross(d, e2, p);
  cross(s, e1, q);
  const double det = dot(e1, p);
  if (det == 0) return -1;
  const double u = dot(s, p) / det, v = dot(d, q) / det;
  return std::min({u, v, 1 - u - v});
}

void check_mesh(const char* name) {
  const fs::path file = fs::path(RAYLINE_ASSETS_DIR) / name;
  if (!fs::exists(file)) GTEST_SKIP() << file << " not fetched (scripts/fetch_assets.sh)";
  RL_GPU_CONTEXT(ctx);
  const Mesh m = load(file);
  ASSERT_GT(m.n, 10000u);
  const EmbreeRef ref(m.records, m.n);
  // A camera 2.5 extents in front of the mesh, looking at its centre.
  const scene::Float3 c = (m.bounds.lo + m.bounds.hi) * 0.5f, e = m.bounds.extent();
  const float ext = std::max({e.x, e.y, e.z});
  scene::Camera cam;
  cam.position = c + scene::Float3{0.3f * ext, 0.4f * ext, 2.5f * ext};
  cam.look_at = c;
  cam.up = {0, 1, 0};
  cam.fov_y_deg = 30;
  const auto rays = tiled_camera_rays(cam, 160, 120);
  const auto inside = random_rays(m.bounds, 20000, 5);
  auto block = upload_block(*ctx, m.records, m.n);
  for (const auto& [what, set] : {std::pair{"camera", &rays}, std::pair{"random inside", &inside}}) {
    auto q = upload_rays(*ctx, *set);
    std::vector<GpuHit> hits(set->size());
    std::vector<std::uint8_t> any(set->size());
    intersect_closest(*ctx, *block, *q, hits);
    intersect_any(*ctx, *block, *q, any);
    std::size_t same = 0, misses = 0, ties = 0, cracks = 0, wrong = 0, any_wrong = 0, any_cracks = 0;
    for (std::size_t i = 0; i < set->size(); ++i) {
      const GpuRay& r = (*set)[i];
      const EmbreeRef::Hit e = ref.closest(r);
      const GpuHit& g = hits[i];
      // The nearer of the two answers (by the plane distance in double) is the triangle
      // the other engine passed by: a crack when the ray meets it at its edge.
      auto crack = [&] {
        const std::uint32_t p = e.prim == kNoHit ? g.prim
                                : g.prim == kNoHit ? e.prim
                                : (plane_t(m.records, e.prim, r) < plane_t(m.records, g.prim, r) ? e.prim : g.prim);
        return edge_distance(m.records, p, r) < 1e-5;
      };
      if (e.prim == g.prim) {
        if (e.prim == kNoHit) ++misses;
        else if (close(g.t, e.t)) ++same;
        else ++wrong;
      } else if (e.prim != kNoHit && g.prim != kNoHit && close(g.t, e.t) &&
                 close(plane_t(m.records, g.prim, r), plane_t(m.records, e.prim, r))) {
        ++ties;
      } else if (crack()) {
        ++cracks;
        std::printf("  crack: ray %zu %s: gpu prim %d t %.9g, embree prim %d t %.9g\n", i, ray_text(r).c_str(),
                    int(g.prim), g.t, int(e.prim), e.t);
      } else {
        ++wrong;
        ADD_FAILURE() << name << " " << what << " ray " << i << " " << ray_text(r) << ": gpu prim " << int(g.prim)
                      << " t " << g.t << ", embree prim " << int(e.prim) << " t " << e.t;
      }
      if (ref.occluded(r) != (any[i] != 0)) {
        // Occlusion differs only through the same edge cracks (the ray meets nothing else).
        if (crack()) ++any_cracks;
        else ++any_wrong;
      }
    }
    std::printf("[%s, %s] %zu rays: %zu same hits, %zu misses, %zu ties, %zu edge cracks, %zu wrong; any hit: %zu "
                "cracks, %zu wrong\n",
                name, what, set->size(), same, misses, ties, cracks, wrong, any_cracks, any_wrong);
    EXPECT_EQ(wrong, 0u);
    EXPECT_EQ(any_wrong, 0u);
    EXPECT_LE(ties * 200, set->size()) << "ties should be rare (< 0.5 %)";
    EXPECT_LE((cracks + any_cracks) * 1000, set->size()) << "edge cracks should be very rare (< 0.1 %)";
    EXPECT_GT(same, set->size() / 20) << "the rays should mostly meet the mesh";
  }
}

}  // namespace

TEST(GpuRealMeshes, StanfordBunny) { check_mesh("bunny.obj"); }
TEST(GpuRealMeshes, StanfordDragon) { check_mesh("dragon.ply"); }

// GPU traversal against Embree 3 on the same block records: the same closest
// prim with |t_gpu - t_embree| <= 1e-5 max(1, t), and the same any-hit answers, on random
// soups, generated-scene blocks, clipped intervals, axis-aligned rays, rays starting inside
// boxes, empty and tiny blocks, every build quality, and more rays than one dispatch binds.
// Every ray the kernels call certain must agree exactly; doubtful rays are counted.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <random>
#include <unistd.h>

#include "gpu_test_util.hpp"
#include "render/vulkan/gpu_bvh.hpp"
#include "tests/gpu/ray_workloads.hpp"
#include "render/partition/block_file.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/generators.hpp"

namespace fs = std::filesystem;
using namespace rayline;
using namespace rayline::gpu;
using namespace rayline::gpu::testing;

namespace {

scene::Bounds unit_box(float pad) {
  scene::Bounds b;
  b.lo = {-pad, -pad, -pad};
  b.hi = {1 + pad, 1 + pad, 1 + pad};
  return b;
}

void expect_agree(const Agreement& a, const char* what) {
  std::printf("[%s] %s\n", what, a.summary().c_str());
  EXPECT_EQ(a.mismatches, 0u) << what << ": " << a.summary();
  EXPECT_EQ(a.any_mismatches, 0u) << what << ": " << a.summary();
  // Doubtful rays (near ties: coplanar overlapping faces, shared edges; hits at the ends of
  // the interval; grazing triangles) go to the CPU in a render: they must stay rare.
  EXPECT_LE(a.doubtful_fraction(), 0.01) << what << ": doubtful rays should be rare (< 1 %)";
  EXPECT_GT(a.hits, 0u) << what;
}

// A generated scene, partitioned into `blocks` block files; returns the records of the
// block with the most triangles and that block's info, and the scene description.
struct SceneBlock {
  std::vector<unsigned char> records;
  std::uint64_t n = 0;
  partition::BlockInfo info;
  scene::Scene scene;
};

SceneBlock generated_block(const std::string& generator, std::uint64_t triangles, std::uint32_t blocks) {
  const fs::path dir = fs::temp_directory_path() / ("rayline-gpu-" + generator + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  scene::Bounds bounds;
  const partition::TriangleSource source = [&](const scene::TriangleBatchFn& fn) {
    scene::ImportStats st;
    scene::TriangleBatcher batcher([&](std::span<const scene::Triangle> batch) {
      for (const auto& t : batch) {
        st.bounds.extend(t.v0), st.bounds.extend(t.v1), st.bounds.extend(t.v2);
        ++st.triangles;
      }
      fn(batch);
    });
    scene::run_generator(generator, triangles, 3, batcher);
    batcher.flush();
    bounds = st.bounds;
    return st;
  };
  partition::PartitionOptions opt;
  opt.blocks = blocks;
  const auto res = partition::partition_triangles(source, generator, dir.string(), opt);
  SceneBlock sb;
  const auto& biggest = *std::max_element(res.index.blocks.begin(), res.index.blocks.end(),
                                          [](const auto& a, const auto& b) { return a.triangles < b.triangles; });
  sb.info = biggest;
  const partition::BlockFile bf = partition::read_block((fs::path(res.dir) / biggest.file).string());
  partition::encode_records(bf.triangles, sb.records);
  sb.n = bf.triangles.size();
  scene::find_generator(generator)->describe(sb.scene, bounds);
  fs::remove_all(dir);
  return sb;
}

}  // namespace

TEST(GpuHits, RandomSoupsRandomRays) {
  RL_GPU_CONTEXT(ctx);
  Agreement total;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const std::size_t n = 20000;
    const auto rec = soup_records(n, seed, seed == 3 ? 0.1f : 0.05f);
    const EmbreeRef ref(rec, n);
    const auto rays = random_rays(unit_box(0.2f), 30000, 100 + seed);
    const Agreement a = run_and_compare(*ctx, rec, n, rays, ref);
    expect_agree(a, ("soup seed " + std::to_string(seed)).c_str());
    total.rays += a.rays, total.doubtful += a.doubtful, total.any_doubtful += a.any_doubtful;
  }
  std::printf("random soups: %zu rays, doubtful %zu closest, %zu any hit (%.4f %%)\n", total.rays, total.doubtful,
              total.any_doubtful, 100 * total.doubtful_fraction());
}

// Rays aimed exactly at the shared edges and vertices of a tessellated, tilted surface —
// where the two engines' non-watertight tests crack differently (on lavapipe the kernel's
// own guess differs from Embree for ~40 % of them). The kernel must flag these rays
// doubtful rather than guess, and decide the control rays aimed inside triangles: every
// ray it calls certain agrees with Embree.
TEST(GpuHits, RaysAtSharedEdgesAreDoubtfulNotWrong) {
  RL_GPU_CONTEXT(ctx);
  const int n = 37;  // 37 x 37 cells, two triangles each, on z = 0.3 x + 0.1 y + 0.2
  auto vtx = [&](int i, int j) {
    const float x = float(i) / float(n), y = float(j) / float(n);
    return scene::Float3{x, y, 0.3f * x + 0.1f * y + 0.2f};
  };
  std::vector<unsigned char> rec;
  auto add = [&](scene::Float3 a, scene::Float3 b, scene::Float3 c) {
    const float v[9] = {a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z};
    unsigned char r[40] = {};
    std::memcpy(r, v, 36);
    rec.insert(rec.end(), r, r + 40);
  };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      add(vtx(i, j), vtx(i + 1, j), vtx(i + 1, j + 1));
      add(vtx(i, j), vtx(i + 1, j + 1), vtx(i, j + 1));
    }
  const std::size_t tris = rec.size() / 40;
  const EmbreeRef ref(rec, tris);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<GpuRay> rays;
  for (int k = 0; k < 20000; ++k) {
    const int i = 1 + int(u(rng) * float(n - 2)), j = 1 + int(u(rng) * float(n - 2));
    const scene::Float3 a = vtx(i, j), b = vtx(i + (k % 3 == 0), j + (k % 3 == 1 ? 0 : 1));  // an edge (or a vertex)
    const float s = k % 5 == 0 ? 0.0f : u(rng);
    scene::Float3 target = a + (b - a) * s;
    if (k % 4 == 3) target = (vtx(i, j) + vtx(i + 1, j) + vtx(i + 1, j + 1)) * (1.0f / 3.0f);  // control: inside
    const scene::Float3 o{u(rng) * 2 - 0.5f, u(rng) * 2 - 0.5f, 1.5f + u(rng)};
    rays.push_back(make_ray(o, target - o));
  }
  const Agreement a = run_and_compare(*ctx, rec, tris, rays, ref);
  std::printf("[shared edges] %s\n", a.summary().c_str());
  EXPECT_EQ(a.mismatches, 0u) << a.summary();
  EXPECT_EQ(a.any_mismatches, 0u) << a.summary();
  EXPECT_GE(a.doubtful, a.rays * 3 / 4 - a.rays / 100) << "every ray through a shared edge should be doubtful";
  EXPECT_GE(a.hits, a.rays / 4 - a.rays / 100) << "rays aimed inside a triangle should be decided";
  // The CPU mirror flags the same rays (it fuses its fmas, lavapipe does not: the plain
  // answers differ on these rays, the flags must not).
  const bvh::FlatBvh flat = bvh::build(rec, tris, GpuBuildOptions{});
  auto block = upload_block(*ctx, rec, tris);
  auto q = upload_rays(*ctx, rays);
  std::vector<GpuHit> hits(rays.size());
  std::vector<std::uint8_t> any(rays.size());
  intersect_closest(*ctx, *block, *q, hits);
  intersect_any(*ctx, *block, *q, any);
  std::size_t flags = 0, differ = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const GpuHit c = bvh::closest(flat, rays[i]);
    const std::uint8_t ca = bvh::any(flat, rays[i]);
    flags += doubtful(c) != doubtful(hits[i]) || (ca & kAnyDoubtful) != (any[i] & kAnyDoubtful);
    if (!doubtful(c) && !doubtful(hits[i])) differ += c.prim != hits[i].prim;
    if (!(ca & kAnyDoubtful) && !(any[i] & kAnyDoubtful)) differ += ca != any[i];
  }
  std::printf("[shared edges] mirror vs kernel: %zu flags differ, %zu certain answers differ\n", flags, differ);
  EXPECT_EQ(differ, 0u);
  EXPECT_LE(flags * 100, rays.size());
}

// The CPU mirror of the kernel (gpu_bvh.cpp) gives the GPU's answers: same prim, t within
// an ulp or two (Vulkan's division is 2.5 ulp), same any-hit, same doubt flags (the
// mirror fuses its fmas and lavapipe does not, so a value right at a margin may flip a
// flag: at most 1 ray in 1 000).
TEST(GpuHits, CpuMirrorMatchesKernel) {
  RL_GPU_CONTEXT(ctx);
  const std::size_t n = 5000;
  const auto rec = soup_records(n, 9);
  const bvh::FlatBvh b = bvh::build(rec, n, GpuBuildOptions{});
  const auto rays = random_rays(unit_box(0.1f), 10000, 5);
  auto block = upload_block(*ctx, rec, n);
  auto q = upload_rays(*ctx, rays);
  std::vector<GpuHit> hits(rays.size());
  std::vector<std::uint8_t> any(rays.size());
  intersect_closest(*ctx, *block, *q, hits);
  intersect_any(*ctx, *block, *q, any);
  int differ = 0, flags = 0, doubtful_rays = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const GpuHit c = bvh::closest(b, rays[i]);
    const float ct = hit_t(c), gt = hit_t(hits[i]);
    const std::uint8_t ca = bvh::any(b, rays[i]);
    flags += doubtful(c) != doubtful(hits[i]) || (ca & kAnyDoubtful) != (any[i] & kAnyDoubtful);
    doubtful_rays += doubtful(hits[i]);
    if (!doubtful(c) && !doubtful(hits[i]))
      differ += c.prim != hits[i].prim || std::fabs(ct - gt) > 1e-6f * std::max(1.0f, std::fabs(ct));
    if (!(ca & kAnyDoubtful) && !(any[i] & kAnyDoubtful)) differ += ca != any[i];
  }
  std::printf("mirror vs kernel: %zu rays, %d doubtful on the GPU, %d flags differ\n", rays.size(), doubtful_rays, flags);
  EXPECT_EQ(differ, 0);
  EXPECT_LE(flags * 1000, int(rays.size()));
  EXPECT_EQ(block->bvh_nodes, b.nodes.size());
  EXPECT_EQ(block->leaf_triangles, n);
  EXPECT_LE(block->bvh_depth, bvh::kStackSize - 1);
}

// The flat BVH is a proper tree: every node reached once from the root, child indices and
// leaf ranges in bounds, every triangle in exactly one leaf (Low, Medium) or at least one
// (High: spatial splits), child boxes holding their triangles, the reported depth exact.
TEST(GpuHits, FlatBvhIsWellFormed) {
  const std::size_t n = 20000;
  const auto rec = soup_records(n, 31, 0.05f);
  for (auto q : {GpuBvhQuality::Low, GpuBvhQuality::Medium, GpuBvhQuality::High}) {
    GpuBuildOptions opt;
    opt.quality = q;
    const bvh::FlatBvh b = bvh::build(rec, n, opt);
    std::vector<int> node_seen(b.nodes.size()), tri_seen(b.tris.size()), prim_seen(n);
    int depth = 0;
    std::vector<std::pair<std::uint32_t, int>> todo{{b.root, 1}};
    while (!todo.empty()) {
      const auto [idx, d] = todo.back();
      todo.pop_back();
      ASSERT_LT(idx, b.nodes.size());
      ++node_seen[idx];
      depth = std::max(depth, d);
      for (const bvh::Child& c : b.nodes[idx].c) {
        if (!bvh::is_leaf(c.word)) {
          todo.push_back({c.word, d + 1});
          continue;
        }
        ASSERT_EQ(bvh::leaf_count(c.word), c.count);
        ASSERT_LE(c.count, bvh::kMaxLeafTriangles);
        for (std::uint32_t k = 0; k < c.count; ++k) {
          const std::uint32_t ti = bvh::leaf_first(c.word) + k;
          ASSERT_LT(ti, b.tris.size());
          ++tri_seen[ti];
          const bvh::Tri& t = b.tris[ti];
          ++prim_seen[t.prim];
          if (q != GpuBvhQuality::High) {  // (split references hold only a part of the triangle)
            for (int a = 0; a < 3; ++a)
              for (float x : {t.v0[a], t.v1[a], t.v2[a]}) ASSERT_TRUE(x >= c.lo[a] && x <= c.hi[a]);
          }
        }
      }
    }
    EXPECT_EQ(depth, b.depth);
    EXPECT_LE(b.depth, bvh::kStackSize - 1);
    for (int s : node_seen) ASSERT_EQ(s, 1);
    for (int s : tri_seen) ASSERT_EQ(s, 1);
    for (int s : prim_seen) ASSERT_TRUE(q == GpuBvhQuality::High ? s >= 1 : s == 1);
    std::printf("quality %d: %zu nodes, %zu leaf triangles, depth %d, build %.3f s (Embree %.3f s)\n", int(q),
                b.nodes.size(), b.tris.size(), b.depth, b.seconds, b.embree_seconds);
  }
}

TEST(GpuHits, ClippedIntervalsAxisAlignedAndInsideRays) {
  RL_GPU_CONTEXT(ctx);
  const std::size_t n = 20000;
  const auto rec = soup_records(n, 4);
  const EmbreeRef ref(rec, n);
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);

  // (1) Random [tmin, tmax] sub-intervals: hits outside them must not count.
  std::vector<GpuRay> clipped = random_rays(unit_box(0.2f), 10000, 8);
  for (auto& r : clipped) {
    r.tmin = 0.6f * u(rng);
    r.tmax = r.tmin + 0.6f * u(rng);
  }
  expect_agree(run_and_compare(*ctx, rec, n, clipped, ref), "clipped intervals");

  // (2) Axis-aligned rays (two zero direction components, +-0), and rays with one zero
  // component: no NaN in the slab test.
  std::vector<GpuRay> axis;
  for (int i = 0; i < 9000; ++i) {
    const scene::Float3 o{u(rng) * 1.2f - 0.1f, u(rng) * 1.2f - 0.1f, u(rng) * 1.2f - 0.1f};
    scene::Float3 d{0.0f, 0.0f, 0.0f};
    const int axis_i = i % 3;
    const float s = (i / 3) % 2 ? -1.0f : 1.0f;
    if (i % 9 < 6) {
      d[axis_i] = s;
      d[(axis_i + 1) % 3] = (i % 4 == 0) ? -0.0f : 0.0f;
    } else {
      d[axis_i] = s * 0.6f, d[(axis_i + 1) % 3] = 0.8f;
    }
    axis.push_back(make_ray(o, d));
  }
  expect_agree(run_and_compare(*ctx, rec, n, axis, ref), "axis-aligned");

  // Axis-aligned rays through a triangle's vertex, sliding along the planes of its box's
  // faces: the box test must keep them (conservative). Here Embree's own box and triangle
  // tests (robust mode too) may miss a vertex hit that the inclusive Möller-Trumbore test
  // reports, so the reference is brute force over every triangle with the kernels' own
  // triangle test (bvh::triangle_t): the same closest prim (ties: smaller prim) and t as the
  // kernels' own answer (rays through vertices are doubtful; the guess is still this one).
  std::vector<GpuRay> sliding;
  for (int i = 0; i < 1000; ++i) {
    float v[9];
    std::memcpy(v, rec.data() + std::size_t(i) * 40, 36);
    scene::Float3 o{v[0], v[1], v[2]};
    o[(i + 1) % 3] = -0.5f;
    scene::Float3 d{0, 0, 0};
    d[(i + 1) % 3] = 1.0f;
    sliding.push_back(make_ray(o, d));
  }
  auto block = upload_block(*ctx, rec, n);
  auto q = upload_rays(*ctx, sliding);
  std::vector<GpuHit> hits(sliding.size());
  std::vector<std::uint8_t> any(sliding.size());
  intersect_closest(*ctx, *block, *q, hits);
  intersect_any(*ctx, *block, *q, any);
  const bvh::FlatBvh flat = bvh::build(rec, n, GpuBuildOptions{});
  int wrong = 0, vertex_hits = 0;
  for (std::size_t i = 0; i < sliding.size(); ++i) {
    float best = INFINITY;
    std::uint32_t prim = kNoHit;
    for (const bvh::Tri& t : flat.tris) {
      const float th = bvh::triangle_t(t, sliding[i]);
      if (th >= sliding[i].tmin && th <= sliding[i].tmax && (th < best || (th == best && t.prim < prim)))
        best = th, prim = t.prim;
    }
    vertex_hits += prim == i;
    wrong += hits[i].prim != prim || (prim != kNoHit && !close(hit_t(hits[i]), best)) ||
             ((any[i] & kAnyOccluded) != 0) != (prim != kNoHit);
  }
  std::printf("[axis-aligned through vertices] %zu rays, %d through their own triangle's vertex, %d differ from brute force\n",
              sliding.size(), vertex_hits, wrong);
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(vertex_hits, 500);

  // (3) Rays starting inside boxes: from points on triangles (just off the surface).
  std::vector<GpuRay> inside;
  std::mt19937_64 rng2(5);
  for (int i = 0; i < 8000; ++i) {
    float v[9];
    std::memcpy(v, rec.data() + std::size_t(i * 2) * 40, 36);
    const float a = u(rng), b = u(rng) * (1 - a);
    const scene::Float3 o{v[0] + a * (v[3] - v[0]) + b * (v[6] - v[0]), v[1] + a * (v[4] - v[1]) + b * (v[7] - v[1]),
                          v[2] + a * (v[5] - v[2]) + b * (v[8] - v[2])};
    inside.push_back(make_ray(o, random_direction(rng2), 1e-4f, INFINITY));
  }
  expect_agree(run_and_compare(*ctx, rec, n, inside, ref), "inside boxes");
}

// Far from the coordinate origin (the worst case for the slab test's fma(lo, inv, -o*inv)
// cancellation): a soup around (3000, -7000, 1500), rays starting on its triangles and
// random rays among them; against Embree and, for conservativeness, brute force with the
// kernels' own triangle test.
TEST(GpuHits, FarFromTheOrigin) {
  RL_GPU_CONTEXT(ctx);
  const std::size_t n = 20000;
  auto rec = soup_records(n, 15, 0.05f);
  const float shift[3] = {3000.0f, -7000.0f, 1500.0f};
  for (std::size_t i = 0; i < n; ++i) {
    float v[9];
    std::memcpy(v, rec.data() + i * 40, 36);
    for (int k = 0; k < 9; ++k) v[k] += shift[k % 3];
    std::memcpy(rec.data() + i * 40, v, 36);
  }
  const EmbreeRef ref(rec, n);
  scene::Bounds b;
  b.lo = {shift[0], shift[1], shift[2]};
  b.hi = {shift[0] + 1, shift[1] + 1, shift[2] + 1};
  std::vector<GpuRay> rays = random_rays(b, 6000, 4);
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 6000; ++i) {  // from points on triangles, just off the surface
    float v[9];
    std::memcpy(v, rec.data() + std::size_t(i * 3) * 40, 36);
    const float a = u(rng), c = u(rng) * (1 - a);
    const scene::Float3 o{v[0] + a * (v[3] - v[0]) + c * (v[6] - v[0]), v[1] + a * (v[4] - v[1]) + c * (v[7] - v[1]),
                          v[2] + a * (v[5] - v[2]) + c * (v[8] - v[2])};
    rays.push_back(make_ray(o, random_direction(rng), 1e-3f, INFINITY));
  }
  expect_agree(run_and_compare(*ctx, rec, n, rays, ref), "far from the origin");
  {  // Huge coordinates (a soup scaled to 1e7) with axis-aligned rays: no overflow to NaN.
    auto big = soup_records(5000, 16, 0.05f);
    for (std::size_t i = 0; i < 5000; ++i) {
      float v[9];
      std::memcpy(v, big.data() + i * 40, 36);
      for (float& x : v) x = x * 1e7f - 3e6f;
      std::memcpy(big.data() + i * 40, v, 36);
    }
    const EmbreeRef big_ref(big, 5000);
    std::vector<GpuRay> axis;
    for (int i = 0; i < 3000; ++i) {
      const scene::Float3 o{u(rng) * 1.2e7f - 4e6f, u(rng) * 1.2e7f - 4e6f, u(rng) * 1.2e7f - 4e6f};
      scene::Float3 d{0, 0, 0};
      d[i % 3] = (i / 3) % 2 ? -1.0f : 1.0f;
      axis.push_back(make_ray(o, d));
    }
    expect_agree(run_and_compare(*ctx, big, 5000, axis, big_ref), "huge coordinates, axis-aligned");
  }
  // Brute force on a subset: the box test culls nothing the triangle test hits.
  auto block = upload_block(*ctx, rec, n);
  auto q = upload_rays(*ctx, rays);
  std::vector<GpuHit> hits(rays.size());
  intersect_closest(*ctx, *block, *q, hits);
  const bvh::FlatBvh flat = bvh::build(rec, n, GpuBuildOptions{});
  int wrong = 0;
  for (std::size_t i = 0; i < rays.size(); i += 12) {
    float best = INFINITY;
    std::uint32_t prim = kNoHit;
    for (const bvh::Tri& t : flat.tris) {
      const float th = bvh::triangle_t(t, rays[i]);
      if (th >= rays[i].tmin && th <= rays[i].tmax && (th < best || (th == best && t.prim < prim))) best = th, prim = t.prim;
    }
    wrong += hits[i].prim != prim;
  }
  EXPECT_EQ(wrong, 0);
}

TEST(GpuHits, GeneratedSceneBlockCameraAndRandomRays) {
  RL_GPU_CONTEXT(ctx);
  const SceneBlock sb = generated_block("museum-like", 80000, 4);
  ASSERT_GT(sb.n, 1000u);
  const EmbreeRef ref(sb.records, sb.n);
  ASSERT_FALSE(sb.scene.cameras.empty());
  const auto cam = tiled_camera_rays(sb.scene.cameras[0], 128, 96);
  const Agreement a = run_and_compare(*ctx, sb.records, sb.n, cam, ref);
  expect_agree(a, "museum block, camera rays");
  const auto rnd = random_rays(sb.info.cell, 20000, 17);
  const Agreement b = run_and_compare(*ctx, sb.records, sb.n, rnd, ref);
  expect_agree(b, "museum block, random rays in its cell");
  std::printf("museum block %u: %llu triangles, doubtful (closest): %zu + %zu of %zu rays\n", sb.info.id,
              static_cast<unsigned long long>(sb.n), a.doubtful, b.doubtful, a.rays + b.rays);
}

TEST(GpuHits, GeneratedClosedHullFromInside) {
  RL_GPU_CONTEXT(ctx);
  const SceneBlock sb = generated_block("boeing-like", 30000, 2);
  const EmbreeRef ref(sb.records, sb.n);
  ASSERT_FALSE(sb.scene.cameras.empty());
  const auto cam = tiled_camera_rays(sb.scene.cameras[0], 96, 64);
  expect_agree(run_and_compare(*ctx, sb.records, sb.n, cam, ref), "boeing block, camera rays");
  expect_agree(run_and_compare(*ctx, sb.records, sb.n, random_rays(sb.info.cell, 10000, 3), ref),
               "boeing block, random rays");
}

TEST(GpuHits, EveryBuildQualityAgrees) {
  RL_GPU_CONTEXT(ctx);
  const std::size_t n = 10000;
  const auto rec = soup_records(n, 12, 0.08f);
  const EmbreeRef ref(rec, n);
  const auto rays = random_rays(unit_box(0.1f), 10000, 4);
  for (auto q : {GpuBvhQuality::Low, GpuBvhQuality::Medium, GpuBvhQuality::High}) {
    GpuBuildOptions opt;
    opt.quality = q;
    const char* name = q == GpuBvhQuality::Low ? "low" : (q == GpuBvhQuality::Medium ? "medium" : "high");
    expect_agree(run_and_compare(*ctx, rec, n, rays, ref, opt), name);
  }
}

TEST(GpuHits, EmptyTinyAndDegenerateBlocks) {
  RL_GPU_CONTEXT(ctx);
  const auto rays = random_rays(unit_box(0.0f), 4000, 21);
  {  // empty block: every ray misses
    std::vector<unsigned char> none;
    auto block = upload_block(*ctx, none, 0);
    EXPECT_EQ(block->triangles(), 0u);
    auto q = upload_rays(*ctx, rays);
    std::vector<GpuHit> hits(rays.size());
    std::vector<std::uint8_t> any(rays.size(), 7);
    intersect_closest(*ctx, *block, *q, hits);
    intersect_any(*ctx, *block, *q, any);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      ASSERT_EQ(hits[i].prim, kNoHit);
      ASSERT_EQ(hits[i].material, kNoHit);
      ASSERT_TRUE(std::isinf(hits[i].t));
      ASSERT_EQ(any[i], 0);
    }
  }
  // 1, 2, 3 and 5 big triangles (a root that is a leaf; a root with two leaves).
  for (std::size_t n : {1u, 2u, 3u, 5u}) {
    const auto rec = soup_records(n, 40 + n, 0.9f);
    const EmbreeRef ref(rec, n);
    const Agreement a = run_and_compare(*ctx, rec, n, rays, ref);
    std::printf("[%zu triangles] %s\n", n, a.summary().c_str());
    EXPECT_EQ(a.mismatches, 0u);
    EXPECT_EQ(a.any_mismatches, 0u);
  }
  // Degenerate (zero-area) and non-finite triangles mixed in: never hit, like Embree.
  std::size_t n = 3000;
  auto rec = soup_records(n, 8, 0.1f);
  for (std::size_t i = 0; i < n; i += 10) {
    float v[9];
    std::memcpy(v, rec.data() + i * 40, 36);
    if (i % 20 == 0) {
      std::memcpy(v + 3, v, 12);  // v1 = v0: a segment
    } else {
      v[4] = NAN;
    }
    std::memcpy(rec.data() + i * 40, v, 36);
  }
  const EmbreeRef ref(rec, n);
  expect_agree(run_and_compare(*ctx, rec, n, rays, ref), "degenerate and non-finite triangles");
}

// More rays than one storage binding holds on lavapipe (128 MiB / 48 B): several dispatches.
TEST(GpuHits, RayQueueLargerThanOneDispatch) {
  RL_GPU_CONTEXT(ctx);
  // One quad (two triangles) in the plane z = 0 over [0,1]^2; material 5.
  const float quad[2][9] = {{0, 0, 0, 1, 0, 0, 1, 1, 0}, {0, 0, 0, 1, 1, 0, 0, 1, 0}};
  std::vector<unsigned char> rec(80);
  for (int k = 0; k < 2; ++k) {
    const std::uint32_t m = 5;
    std::memcpy(rec.data() + k * 40, quad[k], 36);
    std::memcpy(rec.data() + k * 40 + 36, &m, 4);
  }
  const std::size_t n = 3'000'000;
  std::vector<GpuRay> rays(n);
  for (std::size_t i = 0; i < n; ++i) {
    // A grid of downward rays over [-0.5, 1.5]^2 from z = 2: inside the quad they hit at t = 2.
    const float x = -0.5f + 2.0f * float(i % 1733) / 1733.0f, y = -0.5f + 2.0f * float(i / 1733) / 1732.0f;
    rays[i] = make_ray({x, y, 2.0f}, {0, 0, -1});
  }
  auto block = upload_block(*ctx, rec, 2);
  auto q = upload_rays(*ctx, rays);
  std::vector<GpuHit> hits(n);
  GpuDispatchStats st;
  intersect_closest(*ctx, *block, *q, hits, &st);
  std::printf("%zu rays in %u dispatches, kernel %.3f s (%s)\n", n, st.dispatches, st.kernel_seconds,
              st.gpu_timestamps ? "GPU timestamps" : "host time");
  std::size_t bad = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const float x = rays[i].org[0], y = rays[i].org[1];
    const bool in = x > 1e-5f && x < 1 - 1e-5f && y > 1e-5f && y < 1 - 1e-5f && std::fabs(x - y) > 1e-5f;
    const bool out = x < -1e-5f || x > 1 + 1e-5f || y < -1e-5f || y > 1 + 1e-5f;
    if (in) bad += hits[i].prim != (x > y ? 0u : 1u) || hit_t(hits[i]) != 2.0f || hits[i].material != 5u;
    if (out) bad += hits[i].prim != kNoHit;
  }
  EXPECT_EQ(bad, 0u);
  if (ctx->info().cpu_backed) {
    EXPECT_GE(st.dispatches, 2u);  // lavapipe binds 128 MiB at most
  }
}

// Acceptance: the same image bit for bit whatever the memory budget, thread count,
// block count and scheduler (random numbers keyed by pixel/sample/bounce, fixed-point
// accumulation); conservation of rays and samples; the plan is obeyed (no block used
// before its planned load).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "render/engine/ray_log_recorder.hpp"
#include "render/engine/renderer.hpp"
#include "fine_geometry_scene.hpp"
#include "temp_scene.hpp"
#include "small_render.hpp"
#include "z_fighting_scene.hpp"

namespace fs = std::filesystem;
using rayline::engine::render;
using rayline::engine::RenderOptions;
using rayline::engine::RenderResult;

namespace {

RenderOptions base() { return rayline::testing::small_render(40, 40, 4, 7, 2048); }

void expect_sane(const RenderResult& r) {
  EXPECT_EQ(r.counts.created, r.counts.ended()) << "rays created must equal rays ended";
  EXPECT_EQ(r.camera_rays, std::uint64_t(r.width) * std::uint64_t(r.height) * std::uint64_t(r.spp));
  for (std::uint32_t s : r.samples) ASSERT_EQ(s, std::uint32_t(r.spp)) << "every pixel gets exactly spp samples";
  EXPECT_EQ(r.store.unplanned_loads, 0u) << "a block was used before its planned load";
  EXPECT_EQ(r.film_dropped, 0u);
  double sum = 0;
  for (float v : r.rgb) sum += v;
  EXPECT_GT(sum, 0.0);
}

// The in-core render and two at a quarter of its block bytes that differ only by what
// `vary(a, b)` sets; all three sane.
struct QuarterPair {
  RenderResult in_core, a, b;
};
template <class Vary>
QuarterPair quarter_budget_pair(const Vary& vary) {
  RenderOptions a = base();
  RenderOptions b = base();
  QuarterPair r;
  r.in_core = render(base());
  a.memory_budget = b.memory_budget = r.in_core.scene_block_bytes / 4;
  vary(a, b);
  r.a = render(a);
  r.b = render(b);
  expect_sane(r.a);
  expect_sane(r.b);
  return r;
}

}  // namespace

TEST(RenderDeterminism, InCoreVsQuarterBudgetSameImage) {
  RenderOptions a = base();
  const RenderResult ra = render(a);
  expect_sane(ra);
  RenderOptions b = base();
  b.memory_budget = ra.scene_block_bytes / 4;
  const RenderResult rb = render(b);
  expect_sane(rb);
  EXPECT_GT(rb.store.evictions, 0u) << "a 25 % budget must force evictions";
  EXPECT_LE(rb.store.peak_resident_bytes, b.memory_budget);
  EXPECT_EQ(ra.sums, rb.sums);
}

TEST(RenderDeterminism, OneVsTwoThreadsSameImage) {
  RenderOptions a = base();
  a.threads = 1;
  RenderOptions b = base();
  b.threads = 2;
  const RenderResult ra = render(a), rb = render(b);
  expect_sane(ra);
  expect_sane(rb);
  EXPECT_EQ(ra.sums, rb.sums);
}

TEST(RenderDeterminism, EightVsSixtyFourBlocksSameImage) {
  RenderOptions a = base();
  a.blocks = 8;
  RenderOptions b = base();
  b.blocks = 64;
  const RenderResult ra = render(a), rb = render(b);
  expect_sane(ra);
  expect_sane(rb);
  EXPECT_EQ(ra.sums, rb.sums);
}

TEST(RenderDeterminism, SchedulersSameImage) {
  RenderOptions a = base();
  const RenderResult ra = render(a);
  for (const char* name : {"gmb-ca", "budge", "loadanyonce"}) {
    RenderOptions b = base();
    b.scheduler = name;
    b.memory_budget = ra.scene_block_bytes / 3;
    const RenderResult rb = render(b);
    expect_sane(rb);
    EXPECT_EQ(ra.sums, rb.sums) << name;
  }
}

// The same on a z-fighting scene, where the choice between two triangles at the same t up to
// rounding depends on the last bit of Embree's triangle test: the kernel Embree picks for a
// BVH (its width, leaf layout and ISA) must not change the image — so in core (medium
// quality) and out of core (low quality, the Morton builder) agree too.
TEST(RenderDeterminism, BvhQualitySameImageOnZFighting) {
  rayline::testing::ZFightingScene zf;
  rayline::testing::write_z_fighting_scene(zf);
  const std::string& scene = zf.path;
  std::vector<std::vector<std::int64_t>> sums;
  for (const char* q : {"medium", "low", "high"}) {
    RenderOptions o = rayline::testing::small_render(48, 48, 4, 5, 4096, "none");
    o.scene = scene;
    o.blocks = 4;
    o.bvh_quality = q;
    const RenderResult r = render(o);
    expect_sane(r);
    sums.push_back(r.sums);
  }
  std::size_t differ = 0;
  for (std::size_t i = 0; i < sums[0].size(); ++i) differ += sums[0][i] != sums[1][i];
  EXPECT_EQ(differ, 0u) << "of " << sums[0].size() << " film sums differ between medium and low";
  EXPECT_EQ(sums[0], sums[2]) << "medium vs high";
}

// Many blocks over fine geometry: thousands of small triangles cut by split planes, hits
// close to planes on both sides. The image of one block in core (medium BVH) equals the
// image at 17 and 64 blocks, every BVH quality, in core and at 25 % and 10 % budgets.
TEST(RenderDeterminism, FineGeometryManyBlocksEveryBudgetAndQualitySameImage) {
  rayline::testing::FineGeometryScene fine;
  rayline::testing::write_fine_geometry_scene(fine);
  auto options = [&](std::uint32_t blocks, const char* quality) {
    RenderOptions o = rayline::testing::small_render(48, 48, 4, 19, 4096, "none");
    o.scene = fine.path;
    o.blocks = blocks;
    o.bvh_quality = quality;
    o.max_depth = 6;
    return o;
  };
  const RenderResult ref = render(options(1, "medium"));
  expect_sane(ref);
  ASSERT_GT(ref.counts.occluded, 0u) << "shadow rays must meet the geometry";
  for (const std::uint32_t blocks : {17u, 64u})
    for (const char* quality : {"low", "medium", "high"}) {
      if (blocks == 17 && std::string(quality) != "low") continue;
      const RenderResult in_core = render(options(blocks, quality));
      expect_sane(in_core);
      EXPECT_EQ(in_core.sums, ref.sums) << blocks << " blocks, " << quality << ", in core";
      for (const int percent : {25, 10}) {
        RenderOptions o = options(blocks, quality);
        o.memory_budget = in_core.scene_block_bytes * static_cast<std::uint64_t>(percent) / 100;
        const RenderResult r = render(o);
        expect_sane(r);
        EXPECT_GT(r.store.evictions, 0u);
        EXPECT_EQ(r.sums, ref.sums) << blocks << " blocks, " << quality << ", " << percent << " % budget";
      }
    }
}

// `--bvh-quality auto` in core: low at 4 or more triangles per camera ray, else medium; the
// image does not depend on it.
TEST(RenderDeterminism, AutoBvhQualityFollowsTrianglesPerCameraRay) {
  rayline::testing::FineGeometryScene fine;  // 63 488 triangles
  rayline::testing::write_fine_geometry_scene(fine);
  RenderOptions few = rayline::testing::small_render(16, 16, 2, 5, 4096, "none");  // 512 camera rays
  few.scene = fine.path;
  const RenderResult low = render(few);
  expect_sane(low);
  EXPECT_EQ(low.bvh_quality, "low");
  few.bvh_quality = "medium";
  const RenderResult medium = render(few);
  EXPECT_EQ(medium.bvh_quality, "medium");
  EXPECT_EQ(low.sums, medium.sums);
  RenderOptions many = rayline::testing::small_render(128, 128, 1, 5, 4096, "none");  // 16 384 camera rays
  many.scene = fine.path;
  EXPECT_EQ(render(many).bvh_quality, "medium");
}

// A wall of many triangles in the plane x = 0.5 holds most of the scene's centroids, so the
// median split of the first kd node lies in that plane: every ray that meets the wall meets
// it exactly on a split plane, where one cell's query interval ends and the next one's
// begins. The image must be the one-block image at any block count.
TEST(RenderDeterminism, HitsOnASplitPlaneSameImage) {
  rayline::testing::TempScene ts("rayline-splitwall-");
  {  // the wall: x = 0.5, y and z in [0, 1], 40 x 40 quads
    rayline::testing::write_grid_obj(ts.dir / "wall.obj", 40, 40, [](int i, int j) {
      return std::array<double, 3>{0.5, i / 40.0, j / 40.0};
    });
    std::ofstream g(ts.dir / "floor.obj");  // a floor at y = 0 across x in [0, 1.2]
    g << "v 0 0 0\nv 1.2 0 0\nv 1.2 0 1\nv 0 0 1\nf 1 2 3\nf 1 3 4\n";
    // Two small triangles far out along x, so that x has the widest centroid spread.
    std::ofstream h(ts.dir / "far.obj");
    h << "v -2 0 0\nv -1.9 0 0\nv -2 0.1 0\nv 3 0 0\nv 3.1 0 0\nv 3 0.1 0\nf 1 2 3\nf 4 5 6\n";
  }
  const nlohmann::json scene = {
      {"version", 1},
      {"materials", {{"white", {{"albedo", {0.7, 0.7, 0.7}}}}, {"red", {{"albedo", {0.8, 0.2, 0.1}}}}}},
      {"meshes", {{{"name", "wall"}, {"file", "wall.obj"}, {"material", "red"}},
                  {{"name", "floor"}, {"file", "floor.obj"}, {"material", "white"}},
                  {{"name", "far"}, {"file", "far.obj"}, {"material", "white"}}}},
      {"lights", {{{"type", "area"}, {"corner", {0.8, 1.5, 0.4}}, {"edge_u", {0.2, 0, 0}}, {"edge_v", {0, 0, 0.2}},
                   {"emission", {12, 12, 12}}},
                  {{"type", "environment"}, {"radiance", {0.3, 0.35, 0.4}}}}},
      {"cameras", {{"main", {{"position", {1.6, 0.7, 1.3}}, {"look_at", {0.5, 0.45, 0.5}}, {"fov_deg", 50}}}}}};
  std::ofstream(ts.path) << scene.dump(2);
  auto options = [&](std::uint32_t blocks) {
    RenderOptions o = rayline::testing::small_render(64, 64, 4, 23, 4096, "none");
    o.scene = ts.path;
    o.blocks = blocks;
    return o;
  };
  const RenderResult one = render(options(1));
  expect_sane(one);
  for (const std::uint32_t blocks : {2u, 3u, 8u}) {
    const RenderResult r = render(options(blocks));
    expect_sane(r);
    EXPECT_EQ(r.sums, one.sums) << blocks << " blocks";
  }
}

TEST(RenderDeterminism, BvhQualitySameImage) {
  RenderOptions a = base();
  a.bvh_quality = "medium";
  RenderOptions b = base();
  b.bvh_quality = "low";
  const RenderResult ra = render(a), rb = render(b);
  expect_sane(ra);
  expect_sane(rb);
  EXPECT_EQ(ra.sums, rb.sums);
}

TEST(RenderDeterminism, TwoLoadersSameImage) {
  // Two disk->RAM channels: two blocks load (read + BVH build) at once; timing only.
  const auto [in_core, ra, rb] = quarter_budget_pair([](RenderOptions& a, RenderOptions& b) {
    a.loaders = 1;
    b.loaders = 2;
  });
  EXPECT_EQ(ra.loaders, 1);
  EXPECT_EQ(rb.loaders, 2);
  EXPECT_EQ(rb.store.unplanned_loads, 0u);
  EXPECT_EQ(ra.sums, rb.sums);
  EXPECT_EQ(rb.sums, in_core.sums);
}

TEST(RenderDeterminism, EmptySpaceSkippingSameImage) {
  // Going past cells whose occupancy grid a ray misses changes which cells are visited and
  // loaded, never a hit: the same image, with fewer visits.
  const auto [in_core, ra, rb] = quarter_budget_pair([](RenderOptions& a, RenderOptions& b) {
    a.skip_empty = true;
    b.skip_empty = false;
  });
  EXPECT_EQ(rb.counts.skipped, 0u);
  EXPECT_GT(ra.counts.skipped, 0u) << "the built-in room has empty space to skip";
  EXPECT_LT(ra.counts.traced, rb.counts.traced);
  EXPECT_EQ(ra.counts.traced + ra.counts.skipped, rb.counts.traced) << "every skip replaces one visit";
  EXPECT_EQ(ra.sums, rb.sums);
  EXPECT_EQ(ra.sums, in_core.sums);
}

TEST(RenderDeterminism, ReadAheadSameImage) {
  // Reading the next block during the previous build changes timing only.
  const auto [in_core, ra, rb] = quarter_budget_pair([](RenderOptions& a, RenderOptions& b) {
    a.read_ahead = true;
    b.read_ahead = false;
  });
  EXPECT_EQ(rb.store.read_aheads, 0u);
  EXPECT_GT(ra.store.read_aheads, 0u) << "out of core, loads must be read ahead";
  EXPECT_GT(ra.store.recycled_arrays, 0u) << "evicted blocks' arrays must be reused";
  EXPECT_EQ(ra.sums, rb.sums);
  EXPECT_EQ(ra.sums, in_core.sums);
}

TEST(RenderDeterminism, ContinuationInCellSameImage) {
  // Rays a CPU job makes in its own cell are traced in that job instead of waiting in a
  // queue: the same visits, the same rays and the same image, in fewer jobs.
  const auto [in_core, ra, rb] = quarter_budget_pair([](RenderOptions& a, RenderOptions& b) {
    a.batching.continue_in_cell = true;
    b.batching.continue_in_cell = false;
  });
  EXPECT_TRUE(ra.continue_in_cell);
  EXPECT_FALSE(rb.continue_in_cell);
  EXPECT_EQ(ra.counts.traced, rb.counts.traced);
  EXPECT_EQ(ra.counts.created, rb.counts.created);
  EXPECT_EQ(ra.counts.occluded, rb.counts.occluded);
  EXPECT_LT(ra.jobs, rb.jobs) << "rays that stay in their cell need no job of their own";
  EXPECT_EQ(ra.sums, rb.sums);
  EXPECT_EQ(ra.sums, in_core.sums);
}

TEST(RenderDeterminism, CameraJobsSameImage) {
  // One block in core: each job makes the camera rays it traces (and, continuing in the
  // cell, their whole paths). The image and every count are those of camera rays made on
  // the loop's thread and queued; eight blocks (no camera jobs there) agree too.
  RenderOptions a = base(), b = base(), c = base();
  a.blocks = b.blocks = 1;
  // A size that is no multiple of the camera jobs' 8 x 8 tiles, and jobs that end mid-row.
  a.width = b.width = c.width = 37;
  a.height = b.height = c.height = 29;
  b.batching.camera_jobs = false;
  b.batching.continue_in_cell = false;
  const RenderResult ra = render(a), rb = render(b), rc = render(c);
  expect_sane(ra);
  expect_sane(rb);
  EXPECT_TRUE(ra.camera_jobs);
  EXPECT_FALSE(rb.camera_jobs);
  EXPECT_FALSE(rc.camera_jobs) << "camera jobs only with one cell";
  EXPECT_EQ(ra.counts.traced, rb.counts.traced);
  EXPECT_EQ(ra.counts.created, rb.counts.created);
  EXPECT_EQ(ra.counts.paths_ended, rb.counts.paths_ended);
  EXPECT_EQ(ra.sums, rb.sums);
  EXPECT_EQ(ra.sums, rc.sums);
}

namespace {

// The log is the render: one visit per cell visit, one entry per camera ray that met a
// cell, every child recorded after its parent, and a path ray that hands on no path ray
// ends its path once per camera ray (the twin's conservation).
void expect_log_is_render(const rayline::RayLog& log, const RenderResult& rec) {
  EXPECT_EQ(log.visits.size(), rec.counts.traced);
  EXPECT_EQ(log.camera_rays(), rec.camera_rays);
  std::uint64_t ended_paths = 0, entered = 0;
  for (std::uint32_t e : log.entry) entered += e != rayline::RayLog::kNoVisit;
  for (std::size_t v = 0; v < log.visits.size(); ++v) {
    const rayline::RayVisit& x = log.visits[v];
    bool continues = x.kind != 0;
    for (std::uint32_t k = 0; k < x.children; ++k) {
      const std::uint32_t c = log.children[x.first + k];
      ASSERT_GT(c, v) << "a child recorded before its parent";
      continues = continues || log.visits[c].kind == 0;
    }
    ended_paths += continues ? 0 : 1;
  }
  EXPECT_EQ(ended_paths, entered) << "every path that met a cell ends exactly once in the log";
}

}  // namespace

// Recording a ray log (render --record-twin) changes nothing in the image, and the log is
// the render; under a budget, with two threads, rays continuing in their cell.
TEST(RenderDeterminism, RayLogRecordingSameImageAndItsLogIsTheRender) {
  RenderOptions a = base();
  const RenderResult plain = render(a);
  RenderOptions b = base();
  b.memory_budget = plain.scene_block_bytes / 4;
  rayline::engine::RayLogRecorder recorder;
  b.batching.ray_log = &recorder;
  const RenderResult rec = render(b);
  expect_sane(rec);
  EXPECT_TRUE(rec.continue_in_cell);
  EXPECT_EQ(plain.sums, rec.sums);
  expect_log_is_render(recorder.finish(), rec);
}

// The same in core with one block, where jobs make their camera rays and trace whole paths.
TEST(RenderDeterminism, RayLogOfCameraJobsIsTheRender) {
  RenderOptions a = base();
  a.blocks = 1;
  const RenderResult plain = render(a);
  rayline::engine::RayLogRecorder recorder;
  a.batching.ray_log = &recorder;
  const RenderResult rec = render(a);
  expect_sane(rec);
  EXPECT_TRUE(rec.camera_jobs);
  EXPECT_EQ(plain.sums, rec.sums);
  expect_log_is_render(recorder.finish(), rec);
}

// Coplanar, differently tessellated floors (z-fighting: hits at t equal up to rounding):
// one block in core, whose camera jobs trace the camera rays, makes the image of four
// blocks, whose camera rays are queued, at every BVH quality. (Embree's packet queries,
// rtcIntersect8, round t otherwise than rtcIntersect1 and fail this: docs/renderer.md.)
TEST(RenderDeterminism, CameraJobsSameImageOnZFighting) {
  rayline::testing::ZFightingScene zf;
  rayline::testing::write_z_fighting_scene(zf);
  std::vector<std::int64_t> four;
  for (const char* q : {"medium", "low", "high"}) {
    for (const int blocks : {4, 1}) {
      RenderOptions o = rayline::testing::small_render(48, 48, 4, 5, 4096, "none");
      o.scene = zf.path;
      o.blocks = blocks;
      o.bvh_quality = q;
      const RenderResult r = render(o);
      expect_sane(r);
      EXPECT_EQ(r.camera_jobs, blocks == 1);
      if (four.empty()) four = r.sums;
      std::size_t differ = 0;
      for (std::size_t i = 0; i < four.size(); ++i) differ += four[i] != r.sums[i];
      EXPECT_EQ(differ, 0u) << q << " quality, " << blocks << " block(s): film sums differ from 4 blocks, medium";
    }
  }
}

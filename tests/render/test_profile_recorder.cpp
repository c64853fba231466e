// per-cell statistics and replay logs recorded from the real renderer's kernels
// (render/engine/profile_recorder.hpp). The recorder leaves the image unchanged, its
// counts add up to the renderer's own RayCounts, and a renderer-recorded replay log fed
// to the simulator's path-tracing workload (profile from the same render) gives every
// recorded context (stage, frame, tile, bounce, block) exactly its recorded outcome
// totals, with nothing left over and no Markov fallback. Whole pieces match only where the
// simulator batched a context's rays exactly as the renderer did (its job graph has a
// separate Shade stage and other batch sizes); that share is reported, not required.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "render/engine/profile_recorder.hpp"
#include "render/engine/renderer.hpp"
#include "small_render.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "workload/path_trace_workload.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/runtime/runtime_loop.hpp"

using namespace rayline;
using engine::ProfileRecorder;
using engine::ProfileRecorderOptions;

namespace {

engine::RenderOptions base() { return rayline::testing::small_render(32, 24, 2, 5, 1024, "none"); }

std::uint64_t sum_over_blocks(const ProfileRecorder& r, RayStage s, std::size_t cat, std::uint32_t blocks) {
  std::uint64_t t = 0;
  for (std::uint32_t b = 0; b < blocks; ++b) t += r.totals(s, b).at(cat);
  return t;
}

// Per context (the line's first six fields): summed category counts and rays.
using ContextTotals = std::map<std::string, std::map<std::uint32_t, std::uint64_t>>;
ContextTotals context_totals(const ReplayLog& log, std::size_t* pieces = nullptr) {
  const std::string path = ::testing::TempDir() + "/recorder-ctx.log";
  log.save(path, "");
  std::ifstream in(path);
  std::string line;
  ContextTotals t;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("rayline-replay", 0) == 0) continue;
    std::istringstream ss(line);
    std::string f[6], item;
    std::uint64_t rays = 0;
    ss >> f[0] >> f[1] >> f[2] >> f[3] >> f[4] >> f[5] >> rays;
    const std::string key = f[0] + " " + f[1] + " " + f[2] + " " + f[3] + " " + f[4] + " " + f[5];
    auto& m = t[key];
    m[1u << 30] += rays;
    while (ss >> item) {
      const auto c = item.find(':');
      m[static_cast<std::uint32_t>(std::stoul(item.substr(0, c)))] += std::stoull(item.substr(c + 1));
    }
    ++n;
  }
  if (pieces) *pieces = n;
  return t;
}

}  // namespace

TEST(ProfileRecorder, SameImageAndCountsAddUpToTheRenderers) {
  engine::RenderOptions plain = base();
  const engine::RenderResult r0 = engine::render(plain);

  ProfileRecorderOptions po;
  po.tiles_x = 4, po.tiles_y = 3;
  po.replay = true;
  ProfileRecorder rec(po);
  engine::RenderOptions o = base();
  o.batching.recorder = &rec;
  const engine::RenderResult r = engine::render(o);
  EXPECT_EQ(r.sums, r0.sums) << "recording must not change the image";
  EXPECT_EQ(r.counts.created, r.counts.ended());

  const std::uint32_t nb = r.blocks;
  const ProfileRecorder::Mapping m = rec.mapping();
  EXPECT_EQ(rec.camera_total(), r.camera_rays);
  std::uint64_t entries = 0;
  for (std::uint64_t x : rec.entry()) entries += x;
  EXPECT_EQ(entries, r.camera_rays);
  EXPECT_EQ(m.path_rays_traced + m.shadow_rays_traced, r.counts.traced);
  // Every hit ends its ray exactly once (RayCounts::terminated).
  const std::uint64_t hits = sum_over_blocks(rec, RayStage::Intersect, kHit, nb);
  EXPECT_EQ(hits, r.counts.terminated);
  EXPECT_EQ(sum_over_blocks(rec, RayStage::Shade, kTerminate, nb) + sum_over_blocks(rec, RayStage::Shade, kSurvive, nb), hits);
  // Shadow rays the renderer never made count as occluded (the simulator makes one per hit).
  EXPECT_EQ(sum_over_blocks(rec, RayStage::Shadow, kOccluded, nb), r.counts.occluded + m.shadow_not_created);
  EXPECT_GT(hits, 0u);
  EXPECT_GT(m.shadow_rays_traced, 0u);
  if (m.non_face_unrouted == 0) {
    EXPECT_EQ(sum_over_blocks(rec, RayStage::Shadow, kLit, nb), r.counts.unoccluded);
    // Escapes: camera rays missing the scene, and path rays leaving it.
    EXPECT_EQ(rec.entry()[0] + sum_over_blocks(rec, RayStage::Intersect, kEscape, nb), r.counts.escaped);
  }
  std::printf("mapping: path %llu shadow %llu, shadow not created %llu, shadow started in a neighbour %llu, "
              "continuations started in a neighbour %llu, non-face routed %llu, unrouted %llu\n",
              (unsigned long long)m.path_rays_traced, (unsigned long long)m.shadow_rays_traced,
              (unsigned long long)m.shadow_not_created, (unsigned long long)m.shadow_started_in_neighbour,
              (unsigned long long)m.continuation_started_in_neighbour, (unsigned long long)m.non_face_routed,
              (unsigned long long)m.non_face_unrouted);

  // The statistics JSON names every block.
  const std::string js = rec.statistics_json("\"scene\": \"built-in\"");
  EXPECT_NE(js.find("\"format\": \"rayline-render-statistics\""), std::string::npos);
  EXPECT_NE(js.find("{\"id\": " + std::to_string(nb - 1) + ","), std::string::npos);
}

TEST(ProfileRecorder, RendererRecordedLogReplaysEveryContextExactly) {
  ProfileRecorderOptions po;
  po.tiles_x = 4, po.tiles_y = 3;
  po.replay = true;
  ProfileRecorder rec(po);
  engine::RenderOptions o = base();
  o.batching.recorder = &rec;
  const engine::RenderResult r = engine::render(o);
  ASSERT_EQ(rec.mapping().non_face_unrouted, 0u) << "the recorded flow must be closed for exact replay";

  const SceneProfile prof = rec.to_profile(std::vector<Bytes>(r.blocks, Bytes(64) << 20));
  const DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/paper-2A.json");
  auto log = std::make_shared<ReplayLog>(rec.replay());
  ReplayLog again;
  PathTraceOptions opt;
  opt.clients = 1;
  opt.frames_per_client = 1;
  opt.fidelity = Fidelity::Replay;
  opt.replay = log;
  opt.record = &again;
  JobPool pool;
  Schedule s(g, pool);
  PathTraceWorkload wl(g, prof, opt);
  GmbScheduler gmb;
  ExactExecutor ex(s);
  RuntimeLoop loop(gmb, ex, wl, pool, s);
  const RunStats st = loop.run();
  ASSERT_FALSE(st.stalled);
  ASSERT_EQ(wl.frames().size(), 1u);
  EXPECT_TRUE(wl.frames()[0].exact);
  EXPECT_EQ(wl.model().fallback_rays(), 0u) << "every simulated ray had a recorded outcome";
  const RayTally& t = wl.tally();
  EXPECT_EQ(t.created(), t.ended());
  EXPECT_EQ(t.primary, r.camera_rays);

  // Per context (stage, client, frame, tile, bounce, block) and category: how much of what
  // the renderer recorded the simulator's splits reproduced (1 = every context exactly).
  std::size_t rec_pieces = 0, sim_pieces = 0;
  const ContextTotals want = context_totals(rec.replay(), &rec_pieces);
  const ContextTotals got = context_totals(again, &sim_pieces);
  std::uint64_t matched = 0, recorded = 0;
  std::size_t exact_contexts = 0;
  for (const auto& [key, cats] : want) {
    const auto it = got.find(key);
    exact_contexts += it != got.end() && it->second == cats ? 1 : 0;
    for (const auto& [c, n] : cats) {
      if (c == (1u << 30)) continue;
      recorded += n;
      if (it != got.end() && it->second.count(c)) matched += std::min(n, it->second.at(c));
    }
  }
  const double share = double(matched) / double(std::max<std::uint64_t>(1, recorded));
  auto rel = [](std::uint64_t a, std::uint64_t b) { return b ? (double(a) - double(b)) / double(b) : 0.0; };
  std::printf("renderer log: %zu pieces in %zu contexts; simulator: %zu pieces, %llu replayed as whole recorded pieces "
              "(%.1f %%); contexts exact %zu (%.1f %%); recorded outcomes reproduced %.2f %%; tallies vs the render: "
              "hits %+.3f %%, escaped %+.3f %%, lit %+.3f %%\n",
              rec_pieces, want.size(), sim_pieces, (unsigned long long)wl.model().exact_pieces(),
              100.0 * double(wl.model().exact_pieces()) / double(std::max<std::size_t>(1, rec_pieces)), exact_contexts,
              100.0 * double(exact_contexts) / double(std::max<std::size_t>(1, want.size())), 100 * share,
              100 * rel(t.hit, r.counts.terminated), 100 * rel(t.escaped, r.counts.escaped),
              100 * rel(t.lit, r.counts.unoccluded));
  // Entry contexts are fed by the camera alone: always exact.
  for (const auto& [key, cats] : want) {
    if (key.rfind("entry", 0) == 0) {
      EXPECT_EQ(got.at(key), cats) << key;
    }
  }
  // Replay follows each context's recorded order (workload/path_trace_model.cpp), so every
  // context gets exactly its recorded outcomes although the simulator batches differently.
  EXPECT_EQ(got, want);
  EXPECT_EQ(t.hit, r.counts.terminated);
  EXPECT_EQ(t.escaped, r.counts.escaped);
  EXPECT_EQ(t.lit, r.counts.unoccluded);
  EXPECT_EQ(t.occluded, r.counts.occluded + rec.mapping().shadow_not_created);
}

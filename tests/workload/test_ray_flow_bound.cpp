// The expected ray flow (workload/ray_flow_expectation.hpp) against hand-checked cases and
// against the sampled ray-flow model it summarises, and the compute bound
// (workload/compute_bound.hpp) against hand-solved linear programs.
#include <gtest/gtest.h>

#include <map>
#include <tuple>
#include <numeric>
#include <string>

#include "sched/io/platform_loader.hpp"
#include "workload/compute_bound.hpp"
#include "workload/ray_flow_expectation.hpp"
#include "workload/scene_profile.hpp"
#include "workload/two_cell_profile.hpp"

using namespace rayline;

namespace {

const std::string kScenes = std::string(RAYLINE_SCENES_DIR) + "/";

// One node; devices given as JSON compute entries; RAM and (optionally) a GPU memory.
DeviceGraph one_node(const std::string& computes, const std::string& gpu_capacity = "1GiB") {
  const std::string json = R"({"name": "bound-test", "node_types": {"N": {
      "memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"},
                 {"name": "ram", "kind": "host", "capacity": "8GiB"},
                 {"name": "gmem", "kind": "gpu", "capacity": ")" + gpu_capacity + R"("}],
      "compute": [)" + computes + R"(],
      "channels": [{"name": "sata", "kind": "sata", "between": ["disk", "ram"], "duplex": "half",
                    "latency": "10ms", "bandwidth": "150MB/s"},
                   {"name": "pcie", "kind": "pcie", "between": ["ram", "gmem"], "duplex": "full",
                    "latency": "10us", "bandwidth": "12GB/s"}]}},
    "nodes": [{"name": "n0", "type": "N"}]})";
  return parse_platform(json, "bound-test.json");
}

// A compute entry whose RayIntersect, Shade and ShadowIntersect take 64-byte records at
// the given rates (64MB/s = 1 us per record).
std::string device(const std::string& name, const std::string& kind, const std::string& memory, const std::string& intersect,
                   const std::string& shade, const std::string& shadow) {
  return R"({"name": ")" + name + R"(", "kind": ")" + kind + R"(", "memory": ")" + memory + R"(", "timing": {
      "RayIntersect": {"setup": "5us", "rate": {"RayQueue": ")" + intersect + R"("}},
      "Shade": {"setup": "5us", "rate": {"RayQueue": ")" + shade + R"("}},
      "ShadowIntersect": {"setup": "5us", "rate": {"ShadowRayQueue": ")" + shadow + R"("}}}})";
}

// Every camera ray enters block 0 and hits there; no survivor; its shadow ray ends in
// block 0: one record of each ray job type per camera ray.
SceneProfile one_of_each(Bytes block_bytes) {
  SceneProfile p;
  p.max_bounces = 5;
  p.ray_bytes = p.hit_bytes = p.shadow_ray_bytes = 64;
  p.blocks.resize(1);
  p.blocks[0].bytes = block_bytes;
  p.blocks[0].alpha = 1;
  p.blocks[0].beta = 0;
  p.blocks[0].escape = 1;
  p.camera_path = {CameraKey{{{0, 1.0}}, 0}};
  return p;
}

}  // namespace

TEST(RayFlowExpectation, HandCheckedTwoCells) {
  // Unbounded bounces: visits(0) = 1 + 1/4 + 1/16 + ... = 4/3, visits(1) = 1/2 x 4/3;
  // hits = 1/2 x 4/3 = 2/3 (each shaded, each with a shadow ray visiting cell 0 once);
  // survivors = hits x 1/2 = 1/3; rays shot = 1 + 1/3 + 2/3 = 2.
  const RayFlowExpectation e = expected_ray_flow(rayline::testing::two_cell_profile(200), Fidelity::Markov);
  EXPECT_NEAR(e.intersect[0], 4.0 / 3.0, 1e-12);
  EXPECT_NEAR(e.intersect[1], 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(e.shade[0], 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(e.shade[1], 0.0, 1e-12);
  EXPECT_NEAR(e.shadow[0], 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(e.secondary, 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(e.shadow_rays, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(e.rays_shot(), 2.0, 1e-12);
  EXPECT_NEAR(e.block_visits(), 4.0 / 3.0 + 2.0 / 3.0 + 2.0 / 3.0, 1e-12);
  // One bounce: no survivor (the path ends at max_bounces whatever beta says).
  const RayFlowExpectation one = expected_ray_flow(rayline::testing::two_cell_profile(1), Fidelity::Markov);
  EXPECT_NEAR(one.intersect[0], 1.0, 1e-12);
  EXPECT_NEAR(one.intersect[1], 0.5, 1e-12);
  EXPECT_NEAR(one.secondary, 0.0, 1e-12);
  EXPECT_NEAR(one.rays_shot(), 1.5, 1e-12);
}

TEST(RayFlowExpectation, AgreesWithTheSampledModelOnTheMuseum) {
  // An independent reference: push N camera rays through RayFlowModel::split, stage by
  // stage, as the workload does, and count. Counts are sums of multinomial splits, so the
  // means agree within a few standard errors (N = 2e6: ~0.1 % on the totals).
  const SceneProfile p = load_scene_profile(kScenes + "museum.profile.json");
  RayFlowModel model(p, Fidelity::Markov, 7);
  struct Batch {
    RayStage stage;
    int block, bounce;
    std::uint64_t n;
  };
  const std::uint64_t N = 2'000'000;
  // Pending rays per (stage, bounce, block), merged, so each key is split once per pass.
  std::map<std::tuple<int, int, int>, std::uint64_t> pending;
  auto push = [&](RayStage st, int block, int bounce, std::uint64_t n) {
    if (n) pending[{static_cast<int>(st), bounce, block}] += n;
  };
  std::vector<std::uint64_t> out;
  const int keys = static_cast<int>(p.camera_path.size());
  for (int k = 0; k < keys; ++k) push(RayStage::Entry, k, 0, N / static_cast<std::uint64_t>(keys));
  double intersect = 0, shadow = 0, secondary = 0, shadow_rays = 0, camera = 0;
  while (!pending.empty()) {
    const auto first = pending.begin();
    const Batch b{static_cast<RayStage>(std::get<0>(first->first)), std::get<2>(first->first), std::get<1>(first->first),
                  first->second};
    pending.erase(first);
    SplitContext ctx;
    ctx.stage = b.stage;
    ctx.block = b.block;
    ctx.bounce = b.bounce;
    model.split(ctx, b.n, out);
    const auto& nb = b.stage == RayStage::Entry ? std::vector<ProfileNeighbour>{} : p.blocks[static_cast<std::size_t>(b.block)].neighbours;
    switch (b.stage) {
      case RayStage::Entry:
        camera += static_cast<double>(b.n);
        for (std::size_t i = 1; i < out.size(); ++i) push(RayStage::Intersect, static_cast<int>(i - 1), 0, out[i]);
        break;
      case RayStage::Intersect:
        intersect += static_cast<double>(b.n);
        push(RayStage::Shade, b.block, b.bounce, out[kHit]);
        for (std::size_t i = 0; i < nb.size(); ++i) push(RayStage::Intersect, nb[i].block, b.bounce, out[kFirstNeighbour + i]);
        break;
      case RayStage::Shade:
        shadow_rays += static_cast<double>(b.n);
        secondary += static_cast<double>(out[kSurvive]);
        push(RayStage::Shadow, b.block, b.bounce, b.n);
        push(RayStage::Intersect, b.block, b.bounce + 1, out[kSurvive]);
        break;
      case RayStage::Shadow:
        shadow += static_cast<double>(b.n);
        for (std::size_t i = 0; i < nb.size(); ++i) push(RayStage::Shadow, nb[i].block, b.bounce, out[kFirstNeighbour + i]);
        break;
    }
  }
  const RayFlowExpectation e = expected_ray_flow(p, Fidelity::Markov);
  const double total_shadow = std::accumulate(e.shadow.begin(), e.shadow.end(), 0.0);
  const double total_intersect = std::accumulate(e.intersect.begin(), e.intersect.end(), 0.0);
  EXPECT_NEAR(intersect / camera, total_intersect, 0.005 * total_intersect);
  EXPECT_NEAR(shadow / camera, total_shadow, 0.005 * total_shadow);
  EXPECT_NEAR(secondary / camera, e.secondary, 0.005 * e.secondary);
  EXPECT_NEAR(shadow_rays / camera, e.shadow_rays, 0.005 * e.shadow_rays);
  EXPECT_NEAR((camera + secondary + shadow_rays) / camera, e.rays_shot(), 0.005 * e.rays_shot());
}

TEST(ComputeBound, OneDeviceIsTheInverseOfItsCostPerCameraRay) {
  // 1 + 2 + 4 us per camera ray (intersect, shade, shadow): 1/7 M camera rays/s; each
  // camera ray is 2 rays shot (camera + shadow) and 2 block visits.
  const DeviceGraph g = one_node(device("cpu", "cpu", "ram", "64MB/s", "32MB/s", "16MB/s"));
  const SceneProfile p = one_of_each(Bytes(1) << 20);
  const RayFlowExpectation e = expected_ray_flow(p, Fidelity::Markov);
  ASSERT_NEAR(e.rays_shot(), 2.0, 1e-12);
  const ComputeBound b = compute_bound(g, p, e);
  EXPECT_TRUE(b.limit.empty()) << b.limit;
  EXPECT_NEAR(b.camera_rays_per_second, 1e6 / 7, 1e-3);
  EXPECT_NEAR(b.rays_shot_per_second, 2e6 / 7, 1e-3);
  EXPECT_NEAR(b.block_visits_per_second, 2e6 / 7, 1e-3);
  ASSERT_EQ(b.kinds.size(), 1u);
  EXPECT_EQ(b.kinds[0].kind, "cpu");
  EXPECT_NEAR(b.kinds[0].busy_share, 1.0, 1e-9);
}

TEST(ComputeBound, SpecialisationBeatsTheProportionalMix) {
  // A: 1 us per record of every type. B: 1 us per intersection, 4 us per shade or shadow
  // record. Each on its own: A 1/3, B 1/9 M camera rays/s (4/9 together). The optimum lets
  // B intersect (its comparative advantage): B intersects all X and shades/shadows
  // (1 - X)/4; A does the rest: 3X - X - (1 - X)/4 = 1, so X = 5/9 M/s.
  const DeviceGraph g = one_node(device("a", "cpu", "ram", "64MB/s", "64MB/s", "64MB/s") + "," +
                                 device("b", "cpu", "ram", "64MB/s", "16MB/s", "16MB/s"));
  const SceneProfile p = one_of_each(Bytes(1) << 20);
  const ComputeBound b = compute_bound(g, p, expected_ray_flow(p, Fidelity::Markov));
  EXPECT_NEAR(b.camera_rays_per_second, 5e6 / 9, 1e-2);
}

TEST(ComputeBound, OnlyDevicesWhoseMemoryHoldsABlockIntersectIt) {
  // A GPU (1 us per record) beside a CPU (1 us): the block fits the GPU's 1 GiB, so both
  // share the work (2 devices x 1 M records/s over 3 records per camera ray); a 2 GiB
  // block leaves the GPU only shading (1 record of 3): the CPU's intersections bound it.
  const std::string computes = device("cpu", "cpu", "ram", "64MB/s", "64MB/s", "64MB/s") + "," +
                               device("gpu", "gpu", "gmem", "64MB/s", "64MB/s", "64MB/s");
  const DeviceGraph g = one_node(computes, "1GiB");
  const SceneProfile small = one_of_each(Bytes(512) << 20);
  EXPECT_NEAR(compute_bound(g, small, expected_ray_flow(small, Fidelity::Markov)).camera_rays_per_second, 2e6 / 3, 1e-2);
  // Big block: CPU intersects and shadows (2 records), the GPU shades; CPU time 2X = 1.
  const SceneProfile big = one_of_each(Bytes(2) << 30);
  const ComputeBound b = compute_bound(g, big, expected_ray_flow(big, Fidelity::Markov));
  EXPECT_NEAR(b.camera_rays_per_second, 0.5e6, 1e-2);
  for (const ComputeBound::Kind& k : b.kinds) {
    if (k.kind == "gpu") {
      EXPECT_NEAR(k.block_visits_per_second, 0.0, 1e-6);
    }
  }
}

TEST(ComputeBound, NamesTheBlockNoDeviceCanIntersect) {
  const DeviceGraph g = one_node(device("gpu", "gpu", "gmem", "64MB/s", "64MB/s", "64MB/s"), "1GiB");
  const SceneProfile big = one_of_each(Bytes(2) << 30);
  const ComputeBound b = compute_bound(g, big, expected_ray_flow(big, Fidelity::Markov));
  EXPECT_EQ(b.rays_shot_per_second, 0.0);
  EXPECT_NE(b.limit.find("RayIntersect on block 0"), std::string::npos) << b.limit;
}

TEST(ComputeBound, PaperClusterMuseumIsBelowFiftyMillionRaysShot) {
  // The figure docs/performance.md quotes: 8 nodes, museum profile, Markov statistics.
  const DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/paper-cluster.json");
  const SceneProfile p = load_scene_profile(kScenes + "museum.profile.json");
  const RayFlowExpectation e = expected_ray_flow(p, Fidelity::Markov);
  const ComputeBound b = compute_bound(g, p, e);
  EXPECT_TRUE(b.limit.empty()) << b.limit;
  EXPECT_GT(b.rays_shot_per_second, 40e6);
  EXPECT_LT(b.rays_shot_per_second, 50e6);
  // Each device kind is fully used at the optimum (neither is idle in the best split).
  for (const ComputeBound::Kind& k : b.kinds) {
    EXPECT_NEAR(k.busy_share, 1.0, 1e-6) << k.kind;
  }
}

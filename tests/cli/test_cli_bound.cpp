// The compute bound in a run's metrics (metrics.json path_trace.bound,
// workload/compute_bound.hpp) checked against simulations: with I/O made free, a warm run
// of one paper node comes within a few per cent of it and does not pass it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_run.hpp"
#include "scratch_test.hpp"

using rayline::testing::rayline_cli;
namespace fs = std::filesystem;

namespace {
class CliBound : public rayline::testing::ScratchTest {};
nlohmann::json path_trace(const fs::path& dir) {
  std::ifstream in(dir / "metrics.json");
  return nlohmann::json::parse(in)["path_trace"];
}
}  // namespace

TEST_F(CliBound, FreeIoMeetsTheComputeBoundWithoutPassingIt) {
  // Rays are counted when their job ends, so a window holds a little of the work done
  // before it: the tolerance above 1 is that edge (a 12 s window; 24 s gives 0.99).
  const fs::path out = dir_ / "free-io";
  const auto r = rayline_cli("simulate --platform " + std::string(RAYLINE_TEST_DATA) +
                             "/platforms/paper-A-free-io.json --workload museum --clients 2 --duration 16s --warmup 4s"
                             " --start warm --no-progress --no-timeline --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  const auto pt = path_trace(out);
  const auto& b = pt["bound"];
  EXPECT_TRUE(b["limit"].get<std::string>().empty());
  const double bound = b["compute_rays_shot_per_second"].get<double>();
  const double steady = pt["steady_rays_shot_per_second"].get<double>();
  EXPECT_GT(bound, 0);
  EXPECT_GT(steady, 0.85 * bound) << "free I/O: compute is all that limits the run";
  EXPECT_LT(steady, 1.03 * bound) << "no schedule can shoot more rays than the devices can trace";
  EXPECT_NEAR(b["share_of_compute_bound"].get<double>(), steady / bound, 1e-9);
  // The run's own ratio of block visits to rays shot is the expected one (same model).
  const double visits_per_ray = pt["steady_block_visits_per_second"].get<double>() / steady;
  const double expected = b["per_camera_ray"]["block_visits"].get<double>() / b["per_camera_ray"]["rays_shot"].get<double>();
  EXPECT_NEAR(visits_per_ray, expected, 0.1 * expected);
}

// The steady-state test (metrics.json path_trace.steady) on both sides of the line: one
// paper node with the museum's 2 clients absorbs its load (the rays alive do not grow),
// while Boeing's 64 clients under Budge on the same node fill their in-flight budgets
// faster than its disk lets the rays end. The per-second rays-shot series adds up to the rays ended.
TEST_F(CliBound, SteadyStateIsToldFromAnOverload) {
  const std::string common = " --platform paper-A --start warm --duration 8s --no-progress --no-timeline --out ";
  const fs::path ok = dir_ / "steady", over = dir_ / "overload";
  const auto a = rayline_cli("simulate --workload museum --clients 2" + common + ok.string());
  ASSERT_EQ(a.code, 0) << a.all;
  const auto b = rayline_cli("simulate --workload boeing --scheduler budge --clients 64" + common + over.string());
  ASSERT_EQ(b.code, 0) << b.all;
  const auto s = path_trace(ok), o = path_trace(over);
  EXPECT_TRUE(s["steady"]["steady"].get<bool>()) << s["steady"].dump();
  EXPECT_LE(s["steady"]["alive_growth_share_of_shot"].get<double>(), 0.05);
  EXPECT_FALSE(o["steady"]["steady"].get<bool>()) << o["steady"].dump();
  EXPECT_GT(o["steady"]["alive_growth_share_of_shot"].get<double>(), 0.05);
  EXPECT_NE(b.out.find("not a steady state"), std::string::npos) << b.out;
  EXPECT_FALSE(s["steady"]["draining"].get<bool>()) << s["steady"].dump();
  EXPECT_EQ(a.out.find("shrank"), std::string::npos) << a.out;
  for (const auto* pt : {&s, &o}) {
    double sum = 0;
    for (const auto& v : (*pt)["rays_shot_per_second_series"]) sum += v.get<double>();
    EXPECT_EQ((*pt)["rays_shot_per_second_series"].size(), 8u);
    EXPECT_NEAR(sum, (*pt)["rays"]["ended"].get<double>(), 1e-6 * sum + 1);
  }
}

// The other side: Boeing under Rayline's policy on one node A with 32 clients, whose frames
// last longer than the 8 s run, traces rays made before the window; the rays alive shrink.
// Steady (no overload), but the rate is the frames' first seconds: told, not hidden.
TEST_F(CliBound, ABacklogDrainedIsTold) {
  const fs::path out = dir_ / "draining";
  const auto r = rayline_cli("simulate --workload boeing --scheduler rayline --clients 32 --platform paper-A --start warm "
                             "--duration 8s --no-progress --no-timeline --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  const auto p = path_trace(out);
  EXPECT_TRUE(p["steady"]["steady"].get<bool>()) << p["steady"].dump();
  EXPECT_TRUE(p["steady"]["draining"].get<bool>()) << p["steady"].dump();
  EXPECT_LT(p["steady"]["alive_growth_share_of_shot"].get<double>(), -0.05);
  EXPECT_NE(r.out.find("the rays alive shrank by"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("not a steady state"), std::string::npos) << r.out;
}

// --steady strict: in a client sweep such a point is not steady (no peak); loose, the
// default, counts it as before.
TEST_F(CliBound, StrictSweepsTakeNoPeakFromABacklog) {
  const std::string common = " --workload boeing --scheduler rayline --clients 16,32 --platform paper-A --start warm "
                             "--duration 8s --no-progress --no-timeline --out ";
  const auto loose = rayline_cli("simulate" + common + (dir_ / "loose").string());
  ASSERT_EQ(loose.code, 0) << loose.all;
  EXPECT_EQ(loose.out.find("no steady point"), std::string::npos) << loose.out;
  const auto strict = rayline_cli("simulate --steady strict" + common + (dir_ / "strict").string());
  ASSERT_EQ(strict.code, 0) << strict.all;
  EXPECT_NE(strict.out.find("not steady under --steady strict"), std::string::npos) << strict.out;
  EXPECT_NE(strict.out.find("no steady point"), std::string::npos) << strict.out;
  const auto bad = rayline_cli("simulate --steady tight" + common + (dir_ / "bad").string());
  EXPECT_EQ(bad.code, 2) << bad.all;
  EXPECT_NE(bad.err.find("--steady"), std::string::npos) << bad.all;
}

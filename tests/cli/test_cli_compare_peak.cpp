// `rayline compare --clients LIST|auto`: each scheduler swept into OUT/<scheduler>/clients-N/
// and compared at its own peak (the paper's Sec. 6 measurement), the peak's client count in
// compare.csv.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli_run.hpp"
#include "scratch_test.hpp"

using rayline::testing::rayline_cli;
namespace fs = std::filesystem;

namespace {
class CliComparePeak : public rayline::testing::ScratchTest {};

struct Point {
  double rate;
  bool steady;
};
Point point(const fs::path& run) {
  std::ifstream in(run / "metrics.json");
  const auto pt = nlohmann::json::parse(in)["path_trace"];
  return {pt["steady_rays_shot_per_second"].get<double>(), pt["steady"]["steady"].get<bool>()};
}
}  // namespace

TEST_F(CliComparePeak, EachSchedulerIsComparedAtItsOwnPeak) {
  const fs::path out = dir_ / "cmp";
  const auto r = rayline_cli("compare --platform paper-A --workload museum --schedulers gmb,budge --clients 1,2"
                             " --start warm --duration 3s --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  std::ifstream in(out / "compare.json");
  const auto rows = nlohmann::json::parse(in);
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& row : rows) {
    const std::string s = row["scheduler"];
    ASSERT_TRUE(fs::exists(out / s / "clients-1" / "metrics.json")) << s;
    ASSERT_TRUE(fs::exists(out / s / "clients-2" / "metrics.json")) << s;
    const Point one = point(out / s / "clients-1"), two = point(out / s / "clients-2");
    // A steady point beats an unsteady one; between equals, the higher rate.
    const bool second = one.steady != two.steady ? two.steady : two.rate > one.rate;
    const int peak = row["clients"];
    EXPECT_EQ(peak, second ? 2 : 1) << s;
    EXPECT_DOUBLE_EQ(row["steady_rays_shot_per_second"].get<double>(), second ? two.rate : one.rate) << s;
    EXPECT_EQ(row["out"].get<std::string>(), out.string() + "/" + s + "/clients-" + std::to_string(peak));
  }
  std::ifstream csv(out / "compare.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_NE(header.find(",clients"), std::string::npos) << header;
}

// --clients auto:M caps the automatic sweep at M clients; a cap out of range is bad input.
TEST_F(CliComparePeak, AutoSweepStopsAtItsCap) {
  const fs::path out = dir_ / "capped";
  const auto r = rayline_cli("simulate --platform paper-A --workload museum --clients auto:2 --start warm --duration 2s"
                             " --no-progress --no-timeline --out " + out.string());
  ASSERT_TRUE(r.code == 0 || r.code == 1) << r.all;
  EXPECT_TRUE(fs::exists(out / "clients-1" / "metrics.json"));
  EXPECT_FALSE(fs::exists(out / "clients-4")) << r.out;
  const auto bad = rayline_cli("simulate --workload museum --clients auto:0 --out " + (dir_ / "bad").string());
  EXPECT_EQ(bad.code, 2) << bad.all;
  EXPECT_NE(bad.all.find("--clients"), std::string::npos) << bad.all;
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

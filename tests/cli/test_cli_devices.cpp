// `rayline devices` and the --gpu flags: the listing, its JSON, and clear errors
// (exit 2, naming the flag) for a device that does not exist.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "cli/cli_run.hpp"

namespace {
rayline::testing::CliResult run(const std::string& args) { return rayline::testing::rayline_cli(args); }
}  // namespace

TEST(CliDevices, ListsComputeAndMemoryDevicesWithTiming) {
  const auto r = run("devices --gpu none --threads 3");
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("Vulkan devices"), std::string::npos) << r.all;
  EXPECT_NE(r.out.find("(x3)"), std::string::npos) << r.all;
  EXPECT_NE(r.out.find("RayIntersect"), std::string::npos) << r.all;
  EXPECT_NE(r.out.find("disk -> "), std::string::npos) << r.all;
}

TEST(CliDevices, JsonListsLavapipeAsCpuBackedAndAddsTheGpuDevice) {
  const auto r = run("devices --json --gpu none");
  ASSERT_EQ(r.code, 0) << r.all;
  const auto j = nlohmann::json::parse(r.out);
  int cpus = 0;
  for (const auto& c : j["computes"]) cpus += c["kind"] == "cpu";
  EXPECT_GT(cpus, 0);
  std::string lavapipe;
  for (const auto& d : j["vulkan"])
    if (d["cpu_backed"].get<bool>() == true) lavapipe = std::to_string(d["index"].get<int>());
  if (lavapipe.empty()) GTEST_SKIP() << "no CPU-backed Vulkan device (lavapipe) here";
  const auto g = nlohmann::json::parse(run("devices --json --gpu " + lavapipe + " --gpu-memory-budget 256MiB").out);
  bool gpu = false, pcie = false;
  for (const auto& c : g["computes"])
    if (c["kind"] == "gpu") gpu = c["cpu_backed"].get<bool>() && c["timing"].contains("RayIntersect");
  for (const auto& c : g["channels"]) pcie = pcie || (c["kind"] == "pcie" && c["to"] == "W.gpu0mem");
  EXPECT_TRUE(gpu) << g.dump(2);
  EXPECT_TRUE(pcie) << g.dump(2);
  for (const auto& m : g["memories"]) {
    if (m["kind"] == "gpu") {
      EXPECT_EQ(m["capacity_bytes"].get<std::uint64_t>(), 256ull << 20);
    }
  }
}

TEST(CliDevices, MissingGpuIsAClearError) {
  const auto d = run("devices --gpu no-such-gpu");
  EXPECT_EQ(d.code, 2) << d.all;
  EXPECT_NE(d.all.find("--gpu"), std::string::npos) << d.all;
  const auto r = run("render --gpu no-such-gpu --resolution 8x8 --spp 1 -q --out /tmp/rayline-cli-gpu-missing.exr");
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.all.find("no-such-gpu"), std::string::npos) << r.all;
}

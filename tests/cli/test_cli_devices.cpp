// `rayline devices` and the --gpu flags (issue 7): the listing, its JSON, and clear errors
// (exit 2, naming the flag) for a device that does not exist.
#include <gtest/gtest.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

namespace {

struct CliRun {
  int rc = -1;
  std::string out;
};

CliRun run(const std::string& args) {
  CliRun r;
  const std::string cmd = std::string(RAYLINE_BINARY) + " " + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = ::pclose(p);
  r.rc = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

}  // namespace

TEST(CliDevices, ListsComputeAndMemoryDevicesWithTiming) {
  const CliRun r = run("devices --gpu none --threads 3");
  ASSERT_EQ(r.rc, 0) << r.out;
  EXPECT_NE(r.out.find("Vulkan devices"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(x3)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("RayIntersect"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("disk -> "), std::string::npos) << r.out;
}

TEST(CliDevices, JsonListsLavapipeAsCpuBackedAndAddsTheGpuDevice) {
  const CliRun r = run("devices --json --gpu none");
  ASSERT_EQ(r.rc, 0) << r.out;
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
  const CliRun d = run("devices --gpu no-such-gpu");
  EXPECT_EQ(d.rc, 2) << d.out;
  EXPECT_NE(d.out.find("--gpu"), std::string::npos) << d.out;
  const CliRun r = run("render --gpu no-such-gpu --resolution 8x8 --spp 1 -q --out /tmp/rayline-cli-gpu-missing.exr");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("no-such-gpu"), std::string::npos) << r.out;
}

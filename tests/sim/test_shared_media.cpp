// Several GPUs on one PCIe root ("when the plan and reality differ ... several
// GPUs on one PCIe root"): channels naming one medium share its bandwidth in SimGrid, and
// the planner serialises them on its timeline. Each TEST is its own process.
#include <gtest/gtest.h>

#include "sched/io/platform_loader.hpp"
#include "sim/sg_platform.hpp"

using namespace rayline;

namespace {
const char* kTwoGpusOneRoot = R"({
  "name": "root-test",
  "node_types": {"W": {
    "memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"}, {"name": "ram", "kind": "host", "capacity": "64GiB"},
               {"name": "g0", "kind": "gpu", "capacity": "24GiB"}, {"name": "g1", "kind": "gpu", "capacity": "24GiB"}],
    "compute": [{"name": "gpu0", "kind": "gpu", "memory": "g0"}, {"name": "gpu1", "kind": "gpu", "memory": "g1"}],
    "media": [{"name": "root", "bandwidth": "12GB/s"}],
    "channels": [
      {"name": "sata", "between": ["disk", "ram"], "duplex": "half", "latency": "10ms", "bandwidth": "150MB/s"},
      {"name": "pcie0", "between": ["ram", "g0"], "latency": "0us", "bandwidth": "12GB/s", "media": ["root"]},
      {"name": "pcie1", "between": ["ram", "g1"], "latency": "0us", "bandwidth": "12GB/s", "media": ["root"]}]
  }},
  "nodes": [{"name": "W", "type": "W"}]
})";

ChannelId channel(const DeviceGraph& g, const std::string& from, const std::string& to) {
  for (std::size_t c = 0; c < g.channels.size(); ++c)
    if (g.memories[g.channels[c].from].name == from && g.memories[g.channels[c].to].name == to) return static_cast<ChannelId>(c);
  return kNone;
}
}  // namespace

TEST(SharedMedia, LoaderGivesBothPcieChannelsTheRootResource) {
  const DeviceGraph g = parse_platform(kTwoGpusOneRoot, "root.json");
  const Channel& a = g.channels[channel(g, "W.ram", "W.g0")];
  const Channel& b = g.channels[channel(g, "W.ram", "W.g1")];
  ASSERT_EQ(a.resources.size(), 2u);
  EXPECT_EQ(a.resources[1], b.resources[1]);
  EXPECT_EQ(g.resources[a.resources[1]].name, "W.root");
}

TEST(SharedMedia, TwoGpuUploadsShareTheRootInSimGrid) {
  const DeviceGraph g = parse_platform(kTwoGpusOneRoot, "root.json");
  sim::SgPlatform p(g);
  Time t0 = -1, t1 = -1;
  p.start_transfer(channel(g, "W.ram", "W.g0"), 1'200'000'000, [&](const sim::SgCompletion& c) { t0 = c.finish_s; });
  p.start_transfer(channel(g, "W.ram", "W.g1"), 1'200'000'000, [&](const sim::SgCompletion& c) { t1 = c.finish_s; });
  p.run();
  // Alone each would take 0.1 s; sharing the 12 GB/s root they take 0.2 s.
  EXPECT_NEAR(t0, 0.2, 1e-9);
  EXPECT_NEAR(t1, 0.2, 1e-9);
}

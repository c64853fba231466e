// Networks on SimGrid as zones (sim/README.md, "Platform model"): a network is built once,
// as a star of its members' NICs (racks: stars behind uplinks on a backbone), not as one
// route per ordered pair. A transfer alone still takes Eq. 1 exactly; under contention the
// backbone and the uplinks are shared as computed here by hand. Each TEST is its own
// process (one SimGrid engine per process).
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

#include "sched/io/platform_loader.hpp"
#include "sim/sg_platform.hpp"

using namespace rayline;

namespace {

// Two racks of two nodes; NICs 125 MB/s, rack uplinks 250 MB/s, a 100 MB/s backbone with
// 20 us of latency, 100 us on the network: the backbone is the bottleneck between racks.
const char* kRacks = R"({
  "name": "racks",
  "node_types": {"N": {
    "memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"}, {"name": "ram", "kind": "host", "capacity": "8GiB"}],
    "compute": [{"name": "cpu", "kind": "cpu", "memory": "ram"}],
    "channels": [{"name": "sata", "between": ["disk", "ram"], "duplex": "half", "latency": "10ms", "bandwidth": "150MB/s"}]
  }},
  "nodes": [{"name": "n0", "type": "N"}, {"name": "n1", "type": "N"}, {"name": "n2", "type": "N"}, {"name": "n3", "type": "N"}],
  "networks": [{"name": "lan", "latency": "100us", "bandwidth": "1Gb/s",
                "backbone": {"bandwidth": "100MB/s", "latency": "20us"},
                "racks": [{"name": "r0", "uplink": "2Gb/s"}, {"name": "r1", "uplink": "2Gb/s"}],
                "members": [{"node": "n0", "rack": "r0"}, {"node": "n1", "rack": "r0"},
                            {"node": "n2", "rack": "r1"}, {"node": "n3", "rack": "r1"}]}]
})";

constexpr Time kLan = 100e-6, kBackboneLat = 20e-6;
constexpr double kNic = 125e6, kBackbone = 100e6;

ChannelId channel(const DeviceGraph& g, const std::string& name) {
  for (std::size_t c = 0; c < g.channels.size(); ++c)
    if (g.channels[c].name == name) return static_cast<ChannelId>(c);
  ADD_FAILURE() << "no channel " << name;
  return kNone;
}

struct Transfer {
  std::string channel;
  Bytes bytes;
  Time finish = -1;
};

// Starts every transfer at t = 0 and runs to the end.
void run_together(sim::SgPlatform& p, std::vector<Transfer>& ts) {
  for (Transfer& t : ts)
    p.start_transfer(channel(p.graph(), t.channel), t.bytes, [&t](const sim::SgCompletion& c) { t.finish = c.finish_s; });
  p.run();
}

}  // namespace

TEST(NetworkZones, EveryChannelAloneTakesEq1AndIsRoutedThroughItsResources) {
  const DeviceGraph g = parse_platform(kRacks, "racks.json");
  sim::SgPlatform p(g);
  const Bytes bytes = 7'654'321;
  std::size_t next = 0, checked = 0;
  std::vector<ChannelId> order;
  for (std::size_t c = 0; c < g.channels.size(); ++c) order.push_back(static_cast<ChannelId>(c));
  std::function<void()> start_next = [&] {
    if (next == order.size()) return;
    const ChannelId c = order[next++];
    p.start_transfer(c, bytes, [&, c](const sim::SgCompletion& done) {
      EXPECT_NEAR(done.finish_s - done.start_s, g.transfer_time(c, bytes), 1e-9 * g.transfer_time(c, bytes))
          << g.channels[c].name;
      ++checked;
      start_next();
    });
  };
  start_next();
  p.run();
  EXPECT_EQ(checked, g.channels.size());
  for (std::size_t c = 0; c < g.channels.size(); ++c) {
    std::vector<std::string> want;
    for (ResourceId r : g.channels[c].resources) want.push_back(p.resource_link_name(r));
    EXPECT_EQ(p.route_links(static_cast<ChannelId>(c)), want) << g.channels[c].name;
    EXPECT_EQ(p.channel_link_name(static_cast<ChannelId>(c)), "") << g.channels[c].name;
  }
  // Between racks: latency of the network and of the backbone, the backbone's bandwidth.
  EXPECT_DOUBLE_EQ(g.transfer_time(channel(g, "lan:n0->n3"), bytes), kLan + kBackboneLat + bytes / kBackbone);
  EXPECT_DOUBLE_EQ(g.transfer_time(channel(g, "lan:n0->n1"), bytes), kLan + bytes / kNic);
}

TEST(NetworkZones, TwoInterRackTransfersShareTheBackbone) {
  const DeviceGraph g = parse_platform(kRacks, "racks.json");
  sim::SgPlatform p(g);
  // Disjoint NICs, one backbone: 50 MB/s each until the shorter ends at 0.2 s after the
  // latency, then the longer one's remaining 10 MB at the backbone's full 100 MB/s.
  std::vector<Transfer> ts{{"lan:n0->n2", 20'000'000}, {"lan:n1->n3", 10'000'000}};
  run_together(p, ts);
  const Time lat = kLan + kBackboneLat;
  EXPECT_NEAR(ts[1].finish, lat + 10e6 / (kBackbone / 2), 1e-9);
  EXPECT_NEAR(ts[0].finish, lat + 10e6 / (kBackbone / 2) + 10e6 / kBackbone, 1e-9);
  EXPECT_NEAR(p.channel_bytes(channel(g, "lan:n0->n2")), 20e6, 1e-3);
  EXPECT_NEAR(p.resource_bytes(g.networks[0].backbone), 30e6, 1e-3);
}

TEST(NetworkZones, TheBackboneCarriesBothDirectionsAndIntraRackTrafficBypassesIt) {
  const DeviceGraph g = parse_platform(kRacks, "racks.json");
  sim::SgPlatform p(g);
  // Three flows cross the backbone (two ways): 100/3 MB/s each. The two intra-rack flows
  // use only their NICs: 125 MB/s each, untouched by the backbone.
  std::vector<Transfer> ts{{"lan:n0->n2", 10'000'000}, {"lan:n2->n1", 10'000'000}, {"lan:n3->n0", 10'000'000},
                           {"lan:n1->n0", 10'000'000}, {"lan:n3->n2", 10'000'000}};
  run_together(p, ts);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(ts[i].finish, kLan + kBackboneLat + 10e6 / (kBackbone / 3), 1e-9) << ts[i].channel;
  // n1 -> n0 and n3 -> n2 start 20 us earlier (no backbone latency) at a NIC's full
  // 125 MB/s; from then on each shares a NIC with one backbone flow (n0's NIC-in with
  // n3 -> n0, n2's NIC-in with n0 -> n2): 125 - 100/3 MB/s, and both end before those.
  const Time intra = kLan + kBackboneLat + (10e6 - kNic * kBackboneLat) / (kNic - kBackbone / 3);
  EXPECT_NEAR(ts[3].finish, intra, 1e-9);
  EXPECT_NEAR(ts[4].finish, intra, 1e-9);
  EXPECT_LT(intra, ts[0].finish);
}

TEST(NetworkZones, ALargeNetworkIsBuiltWithLinearlyManyLinks) {
  // 300 members: 90 000 channels, but 600 NIC links and no link per channel.
  std::string members;
  std::string nodes;
  for (int i = 0; i < 300; ++i) {
    nodes += std::string(i ? "," : "") + R"({"name": "m)" + std::to_string(i) + R"(", "type": "N"})";
    members += std::string(i ? "," : "") + R"({"node": "m)" + std::to_string(i) + R"("})";
  }
  const std::string text = std::string(R"({"name": "big", "node_types": {"N": {
    "memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"}, {"name": "ram", "kind": "host", "capacity": "8GiB"}],
    "compute": [{"name": "cpu", "kind": "cpu", "memory": "ram"}],
    "channels": [{"name": "sata", "between": ["disk", "ram"], "duplex": "half", "latency": "10ms", "bandwidth": "150MB/s"}]}},
    "nodes": [)") + nodes + R"(], "networks": [{"name": "lan", "latency": "100us", "bandwidth": "1Gb/s", "members": [)" +
                           members + "]}]}";
  const DeviceGraph g = parse_platform(text, "big.json");
  ASSERT_EQ(g.channels.size(), 300u * 299u + 2u * 300u);
  sim::SgPlatform p(g);
  EXPECT_EQ(p.channel_link_name(channel(g, "lan:m17->m230")), "");
  Time t = -1;
  p.start_transfer(channel(g, "lan:m17->m230"), 1'000'000, [&](const sim::SgCompletion& c) { t = c.finish_s; });
  p.run();
  EXPECT_NEAR(t, 100e-6 + 1e6 / 125e6, 1e-12);
}

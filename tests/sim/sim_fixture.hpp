// Test support for the SimGrid platform: a small two-to-three-node DCG built by hand (no
// JSON loader), with every channel kind of Fig. 2.
#pragma once
#include <cmath>
#include <string>
#include <vector>

#include "sched/core/device_graph.hpp"

namespace rayline::testing {

struct SimDcg {
  DeviceGraph g;

  NodeId node(const std::string& n) {
    g.nodes.push_back({n, {}, {}});
    return static_cast<NodeId>(g.nodes.size() - 1);
  }
  MemId mem(NodeId n, const std::string& name, MemoryKind k) {
    g.memories.push_back({g.nodes[n].name + "." + name, k, Bytes(1) << 40, n});
    g.nodes[n].memories.push_back(static_cast<MemId>(g.memories.size() - 1));
    return static_cast<MemId>(g.memories.size() - 1);
  }
  DeviceId dev(MemId m, const std::string& name, ComputeKind k) {
    const NodeId n = g.memories[m].node;
    g.computes.push_back({g.nodes[n].name + "." + name, name, k, m, n});
    g.nodes[n].computes.push_back(static_cast<DeviceId>(g.computes.size() - 1));
    return static_cast<DeviceId>(g.computes.size() - 1);
  }
  ResourceId resource(const std::string& name, double bw) {
    g.resources.push_back({name, bw});
    return static_cast<ResourceId>(g.resources.size() - 1);
  }
  ChannelId channel(const std::string& name, const std::string& kind, MemId a, MemId b, Time lat, double bw,
                    std::vector<ResourceId> res) {
    g.channels.push_back({name, kind, a, b, lat, bw, std::move(res)});
    return static_cast<ChannelId>(g.channels.size() - 1);
  }
};

// Nodes A, B, C. Per node: ram; A has a disk on SATA (half duplex: one resource for both
// directions); A and B have a GPU on PCIe (full duplex: one resource per direction).
// LAN: every node pair, each channel X.ram -> Y.ram uses [X.nic.out, Y.nic.in]; NIC
// speeds differ (A: 1 Gb/s, B and C: 10 Gb/s), so a channel's bandwidth is the min of the
// two NICs, and B -> C is further limited below its NICs (protocol overhead).
struct Cluster {
  static constexpr double kSataBw = 150e6;     // bytes/s
  static constexpr double kPcieBw = 12e9;
  static constexpr double kNic1G = 125e6;
  static constexpr double kNic10G = 1.25e9;
  static constexpr double kBcBw = 1e9;         // B -> C: below both 10G NICs
  static constexpr Time kSataLat = 8e-3;
  static constexpr Time kPcieLat = 10e-6;

  SimDcg b;
  MemId a_disk, a_ram, a_gmem, b_ram, b_gmem, c_ram;
  DeviceId a_cpu, a_gpu, b_gpu;
  ResourceId sata, a_pcie_down, a_pcie_up, b_pcie_down, b_pcie_up;
  ResourceId nic_out[3], nic_in[3];
  ChannelId disk_to_ram, ram_to_disk, a_h2d, a_d2h, b_h2d, b_d2h;
  ChannelId lan[3][3];  // lan[x][y]: X.ram -> Y.ram (x != y)

  static Time lan_latency(int x, int y) { return 100e-6 + 50e-6 * (x + 2 * y); }  // all different

  Cluster() {
    const NodeId na = b.node("A"), nb = b.node("B"), nc = b.node("C");
    a_disk = b.mem(na, "disk", MemoryKind::Disk);
    a_ram = b.mem(na, "ram", MemoryKind::Host);
    a_gmem = b.mem(na, "gpu0.mem", MemoryKind::Gpu);
    b_ram = b.mem(nb, "ram", MemoryKind::Host);
    b_gmem = b.mem(nb, "gpu0.mem", MemoryKind::Gpu);
    c_ram = b.mem(nc, "ram", MemoryKind::Host);
    a_cpu = b.dev(a_ram, "cpu0", ComputeKind::Cpu);
    a_gpu = b.dev(a_gmem, "gpu0", ComputeKind::Gpu);
    b_gpu = b.dev(b_gmem, "gpu0", ComputeKind::Gpu);

    sata = b.resource("A.sata", kSataBw);
    disk_to_ram = b.channel("A.sata.read", "sata", a_disk, a_ram, kSataLat, kSataBw, {sata});
    ram_to_disk = b.channel("A.sata.write", "sata", a_ram, a_disk, kSataLat, kSataBw, {sata});

    a_pcie_down = b.resource("A.pcie0.down", kPcieBw);
    a_pcie_up = b.resource("A.pcie0.up", kPcieBw);
    a_h2d = b.channel("A.pcie0.h2d", "pcie", a_ram, a_gmem, kPcieLat, kPcieBw, {a_pcie_down});
    a_d2h = b.channel("A.pcie0.d2h", "pcie", a_gmem, a_ram, kPcieLat, kPcieBw, {a_pcie_up});
    b_pcie_down = b.resource("B.pcie0.down", kPcieBw);
    b_pcie_up = b.resource("B.pcie0.up", kPcieBw);
    b_h2d = b.channel("B.pcie0.h2d", "pcie", b_ram, b_gmem, kPcieLat, kPcieBw, {b_pcie_down});
    b_d2h = b.channel("B.pcie0.d2h", "pcie", b_gmem, b_ram, kPcieLat, kPcieBw, {b_pcie_up});

    const MemId ram[3] = {a_ram, b_ram, c_ram};
    const char* name[3] = {"A", "B", "C"};
    const double nic[3] = {kNic1G, kNic10G, kNic10G};
    for (int x = 0; x < 3; ++x) {
      nic_out[x] = b.resource(std::string(name[x]) + ".nic.out", nic[x]);
      nic_in[x] = b.resource(std::string(name[x]) + ".nic.in", nic[x]);
    }
    for (int x = 0; x < 3; ++x)
      for (int y = 0; y < 3; ++y) {
        lan[x][y] = kNone;
        if (x == y) continue;
        double bw = std::min(nic[x], nic[y]);
        if (x == 1 && y == 2) bw = kBcBw;
        lan[x][y] = b.channel(std::string("lan:") + name[x] + "->" + name[y], "lan", ram[x], ram[y],
                              lan_latency(x, y), bw, {nic_out[x], nic_in[y]});
      }
    b.g.finalize();
  }
  const DeviceGraph& graph() const { return b.g; }
};

inline double rel_err(double got, double want) { return std::abs(got - want) / std::abs(want); }

}  // namespace rayline::testing

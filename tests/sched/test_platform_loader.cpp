// Platform loader (sched/platform_loader.*): the paper's cluster and its subsets load with
// the device counts of Sec. 6, channels get the contention resources of their medium, and
// every kind of bad input is an InputError naming the file and the JSON path of the field.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "common/error.hpp"
#include "workload/job_set.hpp"
#include "workload/path_trace_model.hpp"
#include "sched/io/platform_loader.hpp"
#include "workload/scene_profile.hpp"
#include "sched/io/timing_samples.hpp"

namespace {

using namespace rayline;
using nlohmann::json;

std::string platform_path(const std::string& name) { return std::string(RAYLINE_PLATFORMS) + "/" + name; }

int count_kind(const DeviceGraph& g, ComputeKind k) {
  int n = 0;
  for (const auto& c : g.computes) n += c.kind == k;
  return n;
}
int count_kind(const DeviceGraph& g, MemoryKind k) {
  int n = 0;
  for (const auto& m : g.memories) n += m.kind == k;
  return n;
}
ChannelId find_channel(const DeviceGraph& g, const std::string& name) {
  for (std::size_t i = 0; i < g.channels.size(); ++i)
    if (g.channels[i].name == name) return static_cast<ChannelId>(i);
  return kNone;
}

// ---------------------------------------------------------------- the shipped platforms

TEST(PlatformLoader, PaperClusterHasThePapersDeviceCounts) {
  const DeviceGraph g = load_platform(platform_path("paper-cluster.json"));
  EXPECT_EQ(g.name, "paper-cluster");
  EXPECT_EQ(g.nodes.size(), 8u);
  EXPECT_EQ(g.computes.size(), 84u);  // 4*9 + 9 + 17 + 17 + 5 (Sec. 6)
  EXPECT_EQ(g.memories.size(), 24u);  // 8 x (disk, RAM, GPU memory)
  EXPECT_EQ(count_kind(g, ComputeKind::Gpu), 8);
  EXPECT_EQ(count_kind(g, ComputeKind::Cpu), 76);
  EXPECT_EQ(count_kind(g, MemoryKind::Disk), 8);
  EXPECT_EQ(count_kind(g, MemoryKind::Host), 8);
  EXPECT_EQ(count_kind(g, MemoryKind::Gpu), 8);
  // 8 nodes x (SATA + PCIe, two directions each) + LAN between all ordered pairs.
  EXPECT_EQ(g.channels.size(), 8u * 4u + 8u * 7u);
  EXPECT_EQ(g.job_types.size(), 7u);
  EXPECT_NE(g.job_type("RayIntersect"), kNone);
  EXPECT_NE(g.job_type("AdditiveCompose"), kNone);
  // Qualified names; count expands to cpu0..cpuN-1.
  EXPECT_NE(g.find_memory("A0.ram"), kNone);
  EXPECT_NE(g.find_memory("A3.gpu0mem"), kNone);
  EXPECT_NE(g.find_compute("A0.cpu7"), kNone);
  EXPECT_EQ(g.find_compute("A0.cpu8"), kNone);
  EXPECT_NE(g.find_compute("C.cpu15"), kNone);
  EXPECT_NE(g.find_compute("R.cpu3"), kNone);
  EXPECT_EQ(g.find_compute("R.cpu4"), kNone);
  EXPECT_NE(g.find_compute("D.gpu0"), kNone);
  // Every compute device sits on its node's memory and the right memory kind.
  for (const auto& c : g.computes) {
    ASSERT_NE(c.memory, kNone);
    EXPECT_EQ(g.memories[c.memory].node, c.node);
    EXPECT_EQ(g.memories[c.memory].kind, c.kind == ComputeKind::Gpu ? MemoryKind::Gpu : MemoryKind::Host);
  }
  // GPU memories: Titan 6 GiB, Titan X 12 GiB (D), GTX 980 4 GiB (R).
  EXPECT_EQ(g.memories[g.find_memory("A0.gpu0mem")].capacity, Bytes(6) << 30);
  EXPECT_EQ(g.memories[g.find_memory("D.gpu0mem")].capacity, Bytes(12) << 30);
  EXPECT_EQ(g.memories[g.find_memory("R.gpu0mem")].capacity, Bytes(4) << 30);
  EXPECT_EQ(g.memories[g.find_memory("B.ram")].capacity, Bytes(8) << 30);
}

TEST(PlatformLoader, ScalingSubsets) {
  struct Case {
    const char* file;
    std::size_t nodes, computes, memories;
  };
  for (const Case& c : {Case{"paper-A.json", 1, 9, 3}, Case{"paper-2A.json", 2, 18, 6}, Case{"paper-3A.json", 3, 27, 9},
                        Case{"paper-4A.json", 4, 36, 12}, Case{"paper-4A+B.json", 5, 45, 15},
                        Case{"paper-4A+B+C.json", 6, 62, 18}, Case{"paper-4A+B+C+D.json", 7, 79, 21},
                        Case{"paper-cluster.json", 8, 84, 24}, Case{"workstation-4gpu.json", 1, 20, 6}}) {
    SCOPED_TRACE(c.file);
    const DeviceGraph g = load_platform(platform_path(c.file));
    EXPECT_EQ(g.nodes.size(), c.nodes);
    EXPECT_EQ(g.computes.size(), c.computes);
    EXPECT_EQ(g.memories.size(), c.memories);
    EXPECT_EQ(g.timing.devices(), static_cast<int>(g.computes.size()));
  }
  const DeviceGraph ws = load_platform(platform_path("workstation-4gpu.json"));
  EXPECT_EQ(count_kind(ws, ComputeKind::Gpu), 4);
  EXPECT_EQ(count_kind(ws, ComputeKind::Cpu), 16);
}

TEST(PlatformLoader, HalfDuplexChannelsShareOneResourceFullDuplexDoNot) {
  const DeviceGraph g = load_platform(platform_path("paper-A.json"));
  const ChannelId up = find_channel(g, "A0.sata:disk->ram"), down = find_channel(g, "A0.sata:ram->disk");
  ASSERT_NE(up, kNone);
  ASSERT_NE(down, kNone);
  ASSERT_EQ(g.channels[up].resources.size(), 1u);
  EXPECT_EQ(g.channels[up].resources, g.channels[down].resources);  // SATA: one head
  EXPECT_DOUBLE_EQ(g.channels[up].bandwidth, 150e6);
  EXPECT_DOUBLE_EQ(g.channels[up].latency, 10e-3);
  const ChannelId h2d = find_channel(g, "A0.pcie0:ram->gpu0mem"), d2h = find_channel(g, "A0.pcie0:gpu0mem->ram");
  ASSERT_NE(h2d, kNone);
  ASSERT_NE(d2h, kNone);
  EXPECT_NE(g.channels[h2d].resources, g.channels[d2h].resources);  // PCIe: full duplex
  EXPECT_DOUBLE_EQ(g.channels[h2d].bandwidth, 12e9);
}

TEST(PlatformLoader, LanBandwidthIsTheSlowerNicAndUsesBothPorts) {
  const DeviceGraph g = load_platform(platform_path("paper-cluster.json"));
  const ChannelId aa = find_channel(g, "lan:A0->A1"), ab = find_channel(g, "lan:A0->B"), ba = find_channel(g, "lan:B->A0");
  ASSERT_NE(aa, kNone);
  ASSERT_NE(ab, kNone);
  ASSERT_NE(ba, kNone);
  EXPECT_DOUBLE_EQ(g.channels[aa].bandwidth, 125e6);   // 1 GbE between A nodes
  EXPECT_DOUBLE_EQ(g.channels[ab].bandwidth, 12.5e6);  // limited by B's 100 Mb NIC
  EXPECT_DOUBLE_EQ(g.channels[ba].bandwidth, 12.5e6);
  EXPECT_DOUBLE_EQ(g.channels[aa].latency, 100e-6);
  EXPECT_EQ(g.channels[ab].from, g.find_memory("A0.ram"));
  EXPECT_EQ(g.channels[ab].to, g.find_memory("B.ram"));
  // Full duplex: sender's NIC-out and receiver's NIC-in.
  ASSERT_EQ(g.channels[ab].resources.size(), 2u);
  EXPECT_EQ(g.resources[g.channels[ab].resources[0]].name, "A0.lan.out");
  EXPECT_EQ(g.resources[g.channels[ab].resources[1]].name, "B.lan.in");
  EXPECT_EQ(g.channels[aa].resources[0], g.channels[ab].resources[0]);  // A0's port is shared
}

TEST(PlatformLoader, TimingIsSecondsPerByteOfTheThroughput) {
  const DeviceGraph g = load_platform(platform_path("paper-cluster.json"));
  const JobTypeId ri = g.job_type("RayIntersect");
  const DeviceId gpu = g.find_compute("A0.gpu0"), cpu = g.find_compute("A0.cpu0"), titanx = g.find_compute("D.gpu0");
  ASSERT_TRUE(g.timing.supports(gpu, ri));
  EXPECT_DOUBLE_EQ(g.timing.at(gpu, ri).setup, 50e-6);
  const int rq = static_cast<int>(DataKind::RayQueue);
  EXPECT_DOUBLE_EQ(g.timing.at(gpu, ri).rate[rq], 1.0 / 640e6);  // 10 M rays/s x 64 B
  EXPECT_DOUBLE_EQ(g.timing.at(cpu, ri).rate[rq], 1.0 / 32e6);   // 0.5 M rays/s x 64 B
  EXPECT_DOUBLE_EQ(g.timing.at(cpu, ri).setup, 5e-6);
  EXPECT_LT(g.timing.at(titanx, ri).rate[rq], g.timing.at(gpu, ri).rate[rq]);  // Titan X is faster
}

TEST(PlatformLoader, ShortestFetchFromDisks) {
  const DeviceGraph g = load_platform(platform_path("paper-cluster.json"));
  std::vector<MemId> disks;
  for (std::size_t m = 0; m < g.memories.size(); ++m)
    if (g.memories[m].kind == MemoryKind::Disk) disks.push_back(static_cast<MemId>(m));
  const auto t = g.shortest_fetch_times(disks, 210'000'000);
  EXPECT_NEAR(t[g.find_memory("A0.ram")], 0.01 + 1.4, 1e-9);  // ~1.4 s from the local HDD
  EXPECT_NEAR(t[g.find_memory("A0.gpu0mem")], 1.41 + 10e-6 + 210e6 / 12e9, 1e-9);
}

// ---------------------------------------------------------------- a small inline platform

json base() {
  return json::parse(R"({
    "name": "t",
    "node_types": {
      "N": {
        "memory": [
          {"name": "disk", "kind": "disk", "capacity": "1TB"},
          {"name": "ram", "kind": "host", "capacity": "8GiB"},
          {"name": "gpu0mem", "kind": "gpu", "capacity": "6GiB"}
        ],
        "compute": [
          {"name": "cpu", "kind": "cpu", "count": 2, "memory": "ram",
           "timing": {"RayIntersect": {"setup": "5us", "rate": {"RayQueue": "32MB/s"}}}},
          {"name": "gpu0", "kind": "gpu", "memory": "gpu0mem",
           "timing": {"RayIntersect": {"setup": "50us", "rate": {"RayQueue": "640MB/s", "SceneData": "10GB/s"}},
                      "Shade": {"setup": "50us"}}}
        ],
        "channels": [
          {"name": "sata", "kind": "sata", "between": ["disk", "ram"], "duplex": "half", "latency": "10ms", "bandwidth": "150MB/s"},
          {"name": "pcie0", "kind": "pcie", "between": ["ram", "gpu0mem"], "duplex": "full", "latency": "10us", "bandwidth": "12GB/s"}
        ]
      }
    },
    "nodes": [{"name": "n0", "type": "N"}, {"name": "n1", "type": "N"}],
    "networks": [{"name": "lan", "latency": "100us", "duplex": "full",
                  "members": [{"node": "n0", "bandwidth": "1Gb/s"}, {"node": "n1", "bandwidth": "100Mb/s"}]}]
  })");
}

DeviceGraph parse(const json& j) { return parse_platform(j.dump(), "inline.json"); }

TEST(PlatformLoader, InlineBaseLoads) {
  const DeviceGraph g = parse(base());
  EXPECT_EQ(g.nodes.size(), 2u);
  EXPECT_EQ(g.computes.size(), 6u);
  EXPECT_EQ(g.memories.size(), 6u);
  EXPECT_EQ(g.channels.size(), 2u * 4u + 2u);
  EXPECT_EQ(g.source_file, "inline.json");
  const DeviceId gpu = g.find_compute("n1.gpu0");
  ASSERT_NE(gpu, kNone);
  EXPECT_TRUE(g.timing.supports(gpu, g.job_type("Shade")));
  EXPECT_FALSE(g.timing.supports(gpu, g.job_type("Accumulate")));  // absent => unsupported
  EXPECT_FALSE(g.timing.supports(g.find_compute("n0.cpu1"), g.job_type("Shade")));
  EXPECT_DOUBLE_EQ(g.timing.at(gpu, g.job_type("RayIntersect")).rate[static_cast<int>(DataKind::SceneData)], 1e-10);
  EXPECT_DOUBLE_EQ(g.channels[find_channel(g, "lan:n0->n1")].bandwidth, 12.5e6);
}

TEST(PlatformLoader, PerNodeOverridesPatchTheTemplate) {
  json j = base();
  j["nodes"][1]["memory"] = json::parse(R"([{"name": "gpu0mem", "capacity": "12GiB"}])");
  j["nodes"][1]["compute"] = json::parse(R"([{"name": "cpu", "count": 4},
      {"name": "gpu0", "timing": {"Shade": null}},
      {"name": "gpu1", "kind": "gpu", "memory": "gpu1mem"}])");
  j["nodes"][1]["memory"].push_back(json::parse(R"({"name": "gpu1mem", "kind": "gpu", "capacity": "4GiB"})"));
  j["nodes"][1]["channels"] = json::parse(
      R"([{"name": "pcie1", "between": ["ram", "gpu1mem"], "latency": "10us", "bandwidth": "12GB/s"}])");
  const DeviceGraph g = parse(j);
  EXPECT_EQ(g.memories[g.find_memory("n1.gpu0mem")].capacity, Bytes(12) << 30);
  EXPECT_EQ(g.memories[g.find_memory("n0.gpu0mem")].capacity, Bytes(6) << 30);  // template untouched
  EXPECT_NE(g.find_compute("n1.cpu3"), kNone);
  EXPECT_EQ(g.find_compute("n0.cpu3"), kNone);
  EXPECT_FALSE(g.timing.supports(g.find_compute("n1.gpu0"), g.job_type("Shade")));
  EXPECT_TRUE(g.timing.supports(g.find_compute("n1.gpu0"), g.job_type("RayIntersect")));
  EXPECT_TRUE(g.timing.supports(g.find_compute("n0.gpu0"), g.job_type("Shade")));
  EXPECT_NE(g.find_compute("n1.gpu1"), kNone);
  EXPECT_NE(find_channel(g, "n1.pcie1:ram->gpu1mem"), kNone);
}

TEST(PlatformLoader, NodeWithoutTypeAndCustomJobTypes) {
  const DeviceGraph g = parse_platform(R"({
    "name": "solo", "job_types": ["Compute"],
    "nodes": [{"name": "w", "memory": [{"name": "disk", "kind": "disk", "capacity": "1TB"},
                                       {"name": "ram", "kind": "host", "capacity": "1GiB"}],
               "compute": [{"name": "cpu", "kind": "cpu", "memory": "ram",
                            "timing": {"Compute": {"rate": {"Generic": "1GB/s"}}}}],
               "channels": [{"name": "ssd", "between": ["disk", "ram"], "latency": "0s", "bandwidth": "1GB/s"}]}]})",
                                       "solo.json");
  EXPECT_EQ(g.job_types, std::vector<std::string>{"Compute"});
  EXPECT_NE(g.find_compute("w.cpu"), kNone);  // count 1: no index suffix
  EXPECT_TRUE(g.timing.supports(0, 0));
}

TEST(PlatformLoader, HalfDuplexNetworkSharesOneNicPerNode) {
  json j = base();
  j["networks"][0]["duplex"] = "half";
  const DeviceGraph g = parse(j);
  const Channel& a = g.channels[find_channel(g, "lan:n0->n1")];
  const Channel& b = g.channels[find_channel(g, "lan:n1->n0")];
  EXPECT_EQ(a.resources[0], b.resources[1]);  // n0's NIC both ways
  EXPECT_EQ(a.resources[1], b.resources[0]);
  EXPECT_EQ(g.resources[a.resources[0]].name, "n0.lan.nic");
}

// ---------------------------------------------------------------- bad input

struct Bad {
  const char* what;
  std::function<void(json&)> edit;
  const char* field;  // expected InputError::field()
  const char* message = "";  // expected substring of the message ("" = any)
};

void expect_error(const std::string& text, const std::string& field, const std::string& message) {
  try {
    parse_platform(text, "bad.json");
    ADD_FAILURE() << "accepted; expected an error at " << field;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "bad.json");
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
  }
}

// Each case edits a fresh copy of the platform `make` returns; every one must fail at its field.
void expect_errors(json (*make)(), const std::vector<Bad>& cases) {
  for (const Bad& c : cases) {
    SCOPED_TRACE(c.what);
    json j = make();
    c.edit(j);
    expect_error(j.dump(), c.field, c.message);
  }
}

TEST(PlatformLoader, BadInputNamesTheField) {
  const std::vector<Bad> cases = {
      {"missing name", [](json& j) { j.erase("name"); }, "name", "missing"},
      {"name wrong type", [](json& j) { j["name"] = 3; }, "name", "string"},
      {"nodes wrong type", [](json& j) { j["nodes"] = json::object(); }, "nodes", "array"},
      {"no nodes", [](json& j) { j["nodes"] = json::array(); }, "nodes", ""},
      {"unknown top-level key", [](json& j) { j["netwroks"] = json::array(); }, "netwroks", "unknown key"},
      {"unknown channel key", [](json& j) { j["node_types"]["N"]["channels"][0]["bandwith"] = "1GB/s"; },
       "node_types.N.channels[0].bandwith", "unknown key"},
      {"unknown node key", [](json& j) { j["nodes"][0]["typ"] = "N"; }, "nodes[0].typ", "unknown key"},
      {"missing node name", [](json& j) { j["nodes"][1].erase("name"); }, "nodes[1].name", "missing"},
      {"duplicate node", [](json& j) { j["nodes"][1]["name"] = "n0"; }, "nodes[1].name", "duplicate"},
      {"unknown node type", [](json& j) { j["nodes"][1]["type"] = "X"; }, "nodes[1].type", "unknown node type"},
      {"duplicate memory", [](json& j) { j["node_types"]["N"]["memory"][2]["name"] = "ram"; },
       "node_types.N.memory[2].name", "duplicate"},
      {"bad memory kind", [](json& j) { j["node_types"]["N"]["memory"][1]["kind"] = "dram"; },
       "node_types.N.memory[1].kind", "disk, host or gpu"},
      {"malformed capacity", [](json& j) { j["node_types"]["N"]["memory"][1]["capacity"] = "8 GiB"; },
       "node_types.N.memory[1].capacity", "expected"},
      {"capacity not a string", [](json& j) { j["node_types"]["N"]["memory"][1]["capacity"] = 8; },
       "node_types.N.memory[1].capacity", "string"},
      {"zero capacity", [](json& j) { j["node_types"]["N"]["memory"][1]["capacity"] = "0B"; },
       "node_types.N.memory[1].capacity", "> 0"},
      {"compute without memory", [](json& j) { j["node_types"]["N"]["compute"][0].erase("memory"); },
       "node_types.N.compute[0].memory", "memory device"},
      {"unknown memory ref", [](json& j) { j["node_types"]["N"]["compute"][1]["memory"] = "vram"; },
       "node_types.N.compute[1].memory", "unknown memory device 'vram'"},
      {"bad compute kind", [](json& j) { j["node_types"]["N"]["compute"][1]["kind"] = "tpu"; },
       "node_types.N.compute[1].kind", "cpu or gpu"},
      {"count not integer", [](json& j) { j["node_types"]["N"]["compute"][0]["count"] = "8"; },
       "node_types.N.compute[0].count", "integer"},
      {"count zero", [](json& j) { j["node_types"]["N"]["compute"][0]["count"] = 0; }, "node_types.N.compute[0].count",
       "integer"},
      {"duplicate compute",
       [](json& j) {
         j["node_types"]["N"]["compute"].push_back(json{{"name", "cpu1"}, {"kind", "cpu"}, {"memory", "ram"}});
       },
       "node_types.N.compute[2].name", "duplicate compute device name 'n0.cpu1'"},
      {"unknown job type",
       [](json& j) { j["node_types"]["N"]["compute"][0]["timing"]["RayTrace"] = json{{"setup", "1us"}}; },
       "node_types.N.compute[0].timing.RayTrace", "unknown job type"},
      {"unknown data kind",
       [](json& j) { j["node_types"]["N"]["compute"][0]["timing"]["RayIntersect"]["rate"]["Rays"] = "1MB/s"; },
       "node_types.N.compute[0].timing.RayIntersect.rate.Rays", "unknown data kind"},
      {"zero rate",
       [](json& j) { j["node_types"]["N"]["compute"][0]["timing"]["RayIntersect"]["rate"]["RayQueue"] = "0MB/s"; },
       "node_types.N.compute[0].timing.RayIntersect.rate.RayQueue", "> 0"},
      {"unknown timing key",
       [](json& j) { j["node_types"]["N"]["compute"][0]["timing"]["RayIntersect"]["setpu"] = "1us"; },
       "node_types.N.compute[0].timing.RayIntersect.setpu", "unknown key"},
      {"bad setup", [](json& j) { j["node_types"]["N"]["compute"][0]["timing"]["RayIntersect"]["setup"] = "5"; },
       "node_types.N.compute[0].timing.RayIntersect.setup", "missing unit"},
      {"negative bandwidth", [](json& j) { j["node_types"]["N"]["channels"][1]["bandwidth"] = "-12GB/s"; },
       "node_types.N.channels[1].bandwidth", "negative"},
      {"zero bandwidth", [](json& j) { j["node_types"]["N"]["channels"][1]["bandwidth"] = "0GB/s"; },
       "node_types.N.channels[1].bandwidth", "> 0"},
      {"bandwidth without /s", [](json& j) { j["node_types"]["N"]["channels"][0]["bandwidth"] = "150MB"; },
       "node_types.N.channels[0].bandwidth", "expected"},
      {"negative cpu_contention",
       [](json& j) { j["node_types"]["N"]["channels"][0]["cpu_contention"] = {{"transfer", -0.5}}; },
       "node_types.N.channels[0].cpu_contention.transfer", "at least 0"},
      {"cpu_contention.exec not a number",
       [](json& j) { j["node_types"]["N"]["channels"][0]["cpu_contention"] = {{"exec", "1x"}}; },
       "node_types.N.channels[0].cpu_contention.exec", ""},
      {"cpu_contention a number", [](json& j) { j["node_types"]["N"]["channels"][0]["cpu_contention"] = 1.5; },
       "node_types.N.channels[0].cpu_contention", "object"},
      {"cpu_contention unknown key",
       [](json& j) { j["node_types"]["N"]["channels"][0]["cpu_contention"] = {{"exe", 1}}; },
       "node_types.N.channels[0].cpu_contention.exe", "unknown key"},
      {"missing latency", [](json& j) { j["node_types"]["N"]["channels"][0].erase("latency"); },
       "node_types.N.channels[0].latency", "missing"},
      {"bad duplex", [](json& j) { j["node_types"]["N"]["channels"][0]["duplex"] = "simplex"; },
       "node_types.N.channels[0].duplex", "half"},
      {"channel to unknown memory", [](json& j) { j["node_types"]["N"]["channels"][0]["between"][1] = "mem"; },
       "node_types.N.channels[0].between[1]", "unknown memory device 'mem'"},
      {"channel to itself", [](json& j) { j["node_types"]["N"]["channels"][0]["between"] = {"ram", "ram"}; },
       "node_types.N.channels[0].between", "different"},
      {"duplicate channel", [](json& j) { j["node_types"]["N"]["channels"][1]["name"] = "sata"; },
       "node_types.N.channels[1].name", "duplicate"},
      {"network unknown node", [](json& j) { j["networks"][0]["members"][1]["node"] = "n7"; },
       "networks[0].members[1].node", "unknown node 'n7'"},
      {"network unknown memory", [](json& j) { j["networks"][0]["members"][0]["memory"] = "nic"; },
       "networks[0].members[0].memory", "unknown memory device 'nic'"},
      {"network missing NIC speed", [](json& j) { j["networks"][0]["members"][0].erase("bandwidth"); },
       "networks[0].members[0].bandwidth", "missing"},
      {"network zero NIC", [](json& j) { j["networks"][0]["members"][0]["bandwidth"] = "0Mb/s"; },
       "networks[0].members[0].bandwidth", "> 0"},
      {"network member twice", [](json& j) { j["networks"][0]["members"][1]["node"] = "n0"; },
       "networks[0].members[1].node", "twice"},
      {"duplicate job type", [](json& j) { j["job_types"] = {"RayIntersect", "RayIntersect"}; }, "job_types[1]",
       "duplicate"},
      {"override error at node path", [](json& j) { j["nodes"][1]["memory"] = {{{"name", "ram"}, {"capacity", "lots"}}}; },
       "nodes[1].memory[0].capacity", "expected"},
      {"override entry without name", [](json& j) { j["nodes"][1]["compute"] = {{{"count", 3}}}; },
       "nodes[1].compute[0].name", "missing"},
      {"unreachable memory (no SATA)",
       [](json& j) { j["node_types"]["N"]["channels"].erase(0); }, "node_types.N.memory[1]",
       "'n0.ram' is unreachable"},
      {"unreachable GPU memory (override)",
       [](json& j) {
         j["nodes"][1]["memory"] = {{{"name", "gpu1mem"}, {"kind", "gpu"}, {"capacity", "1GiB"}}};
         j["nodes"][1]["compute"] = {{{"name", "gpu1"}, {"kind", "gpu"}, {"memory", "gpu1mem"}}};
       },
       "nodes[1].memory[0]", "'n1.gpu1mem' is unreachable"},
      {"no disk at all",
       [](json& j) {
         j["node_types"]["N"]["memory"][0]["kind"] = "host";
       },
       "nodes", "disk"},
      {"control loop: negative per_exec_second",
       [](json& j) { j["control_loop"] = {{"per_job", "1ms"}, {"per_exec_second", -1}}; },
       "control_loop.per_exec_second", "from 0"},
      {"control loop: per_job not a duration", [](json& j) { j["control_loop"] = {{"per_job", "1GB"}}; },
       "control_loop.per_job", ""},
      {"control loop: unknown key", [](json& j) { j["control_loop"] = {{"per_jobs", "1ms"}}; },
       "control_loop.per_jobs", "unknown key"},
      {"control loop: wake not a duration", [](json& j) { j["control_loop"] = {{"wake", "1MB"}}; },
       "control_loop.wake", ""},
      {"control loop: per_camera_ray over a second", [](json& j) { j["control_loop"] = {{"per_camera_ray", "2s"}}; },
       "control_loop.per_camera_ray", "from 0 to 1 s"},
      {"control loop: pickup not a duration", [](json& j) { j["control_loop"] = {{"pickup", 3}}; }, "control_loop.pickup", ""},
      {"clients: unknown memory", [](json& j) { j["clients"] = "n2.ram"; }, "clients", "no memory device named 'n2.ram'"},
      {"clients: not host memory", [](json& j) { j["clients"] = "n1.gpu0mem"; }, "clients", "not a host memory"},
      {"clients: not a string", [](json& j) { j["clients"] = 1; }, "clients", "string"},
  };
  expect_errors(base, cases);
}

// "clients": the host memory where path-tracing clients keep their framebuffers (kNone
// without the key: the workload takes the first host memory).
TEST(PlatformLoader, ClientsNameAHostMemory) {
  json j = base();
  EXPECT_EQ(parse_platform(j.dump(), "p.json").client_memory, kNone);
  j["clients"] = "n1.ram";
  const DeviceGraph g = parse_platform(j.dump(), "p.json");
  EXPECT_EQ(g.client_memory, g.find_memory("n1.ram"));
}

// Channel::cpu_contention: optional (0), on both directions of the channel.
TEST(PlatformLoader, CpuContentionIsOptionalPerChannel) {
  json j = base();
  for (const Channel& c : parse(j).channels) EXPECT_EQ(c.cpu_contention + c.exec_contention, 0.0) << c.name;
  j["node_types"]["N"]["channels"][0]["cpu_contention"] = {{"transfer", 1.25}, {"exec", 0.5}};
  int with = 0;
  for (const Channel& c : parse(j).channels)
    if (c.cpu_contention > 0) {
      EXPECT_EQ(c.cpu_contention, 1.25);
      EXPECT_EQ(c.exec_contention, 0.5);
      EXPECT_NE(c.name.find(".sata:"), std::string::npos) << c.name;
      ++with;
    }
  EXPECT_EQ(with, 4);  // two nodes, both directions
}

TEST(PlatformLoader, ControlLoopIsOptionalAndReadInSeconds) {
  json j = base();
  EXPECT_FALSE(parse_platform(j.dump(), "p.json").loop.modelled());
  EXPECT_EQ(parse_platform(j.dump(), "p.json").loop.per_camera_ray, 0.0);
  j["control_loop"] = {{"per_job", "250us"}, {"per_exec_second", 0.2}, {"wake", "300us"}, {"per_camera_ray", "300ns"}, {"pickup", "60us"}};
  const DeviceGraph g = parse_platform(j.dump(), "p.json");
  EXPECT_DOUBLE_EQ(g.loop.per_camera_ray, 300e-9);
  EXPECT_DOUBLE_EQ(g.loop.pickup, 60e-6);
  EXPECT_DOUBLE_EQ(g.loop.per_job, 250e-6);
  EXPECT_DOUBLE_EQ(g.loop.per_exec_second, 0.2);
  EXPECT_DOUBLE_EQ(g.loop.wake, 300e-6);
  EXPECT_DOUBLE_EQ(g.loop.latency(0.01), 250e-6 + 0.002);
}

// Four nodes in two racks on a backbone: within a rack a channel uses the two NICs; between
// racks also the sender rack's uplink, the backbone and the receiver rack's downlink, and
// runs at the slowest of them, with the backbone's latency added.
json racked() {
  json j = base();
  j["nodes"] = {{{"name", "n0"}, {"type", "N"}}, {{"name", "n1"}, {"type", "N"}},
                {{"name", "n2"}, {"type", "N"}}, {{"name", "n3"}, {"type", "N"}}};
  j["networks"][0] = json::parse(R"({"name": "lan", "latency": "100us", "duplex": "full", "bandwidth": "1Gb/s",
    "backbone": {"bandwidth": "400Mb/s", "latency": "20us"},
    "racks": [{"name": "r0", "uplink": "800Mb/s"}, {"name": "r1", "oversubscription": 4}],
    "members": [{"node": "n0", "rack": "r0"}, {"node": "n1", "rack": "r0"},
                {"node": "n2", "rack": "r1"}, {"node": "n3", "rack": "r1", "bandwidth": "200Mb/s"}]})");
  return j;
}

std::vector<std::string> resource_names(const DeviceGraph& g, const Channel& c) {
  std::vector<std::string> names;
  for (ResourceId r : c.resources) names.push_back(g.resources[r].name);
  return names;
}

TEST(PlatformLoader, RacksAndBackboneGiveInterRackChannelsTheirUplinks) {
  const DeviceGraph g = parse(racked());
  ASSERT_EQ(g.networks.size(), 1u);
  const Network& net = g.networks[0];
  ASSERT_EQ(net.racks.size(), 2u);
  ASSERT_EQ(net.members.size(), 4u);
  EXPECT_EQ(net.members[3].rack, 1);
  EXPECT_DOUBLE_EQ(g.resources[net.backbone].bandwidth, 50e6);
  EXPECT_DOUBLE_EQ(g.resources[net.racks[0].up].bandwidth, 100e6);
  EXPECT_DOUBLE_EQ(g.resources[net.racks[1].down].bandwidth, (125e6 + 25e6) / 4);  // NIC total / 4
  const Channel& inside = g.channels[find_channel(g, "lan:n0->n1")];
  EXPECT_EQ(resource_names(g, inside), (std::vector<std::string>{"n0.lan.out", "n1.lan.in"}));
  EXPECT_DOUBLE_EQ(inside.bandwidth, 125e6);
  EXPECT_DOUBLE_EQ(inside.latency, 100e-6);
  const Channel& across = g.channels[find_channel(g, "lan:n1->n2")];
  EXPECT_EQ(resource_names(g, across),
            (std::vector<std::string>{"n1.lan.out", "lan.r0.up", "lan.backbone", "lan.r1.down", "n2.lan.in"}));
  EXPECT_DOUBLE_EQ(across.bandwidth, 37.5e6);  // r1's downlink, the slowest
  EXPECT_DOUBLE_EQ(across.latency, 120e-6);
  EXPECT_EQ(across.network, 0);
  EXPECT_EQ(g.channels[find_channel(g, "n0.sata:disk->ram")].network, kNone);
  for (const Channel& c : g.channels) {
    if (c.network != 0) continue;
    const bool same_rack = c.name == "lan:n0->n1" || c.name == "lan:n1->n0" || c.name == "lan:n2->n3" || c.name == "lan:n3->n2";
    EXPECT_EQ(c.resources.size(), same_rack ? 2u : 5u) << c.name;
  }
}

TEST(PlatformLoader, BackboneWithoutRacksCarriesEveryPair) {
  json j = base();
  j["networks"][0]["backbone"] = {{"bandwidth", "50Mb/s"}};
  j["networks"][0]["duplex"] = "half";
  const DeviceGraph g = parse(j);
  const Channel& c = g.channels[find_channel(g, "lan:n0->n1")];
  EXPECT_EQ(resource_names(g, c), (std::vector<std::string>{"n0.lan.nic", "lan.backbone", "n1.lan.nic"}));
  EXPECT_DOUBLE_EQ(c.bandwidth, 6.25e6);
  EXPECT_DOUBLE_EQ(c.latency, 100e-6);
}

TEST(PlatformLoader, BadRacksNameTheField) {
  const std::vector<Bad> cases = {
      {"member without rack", [](json& j) { j["networks"][0]["members"][2].erase("rack"); },
       "networks[0].members[2].rack", "missing"},
      {"unknown rack", [](json& j) { j["networks"][0]["members"][2]["rack"] = "r9"; },
       "networks[0].members[2].rack", "unknown rack 'r9'"},
      {"rack on a network without racks", [](json& j) { j["networks"][0].erase("racks"); },
       "networks[0].members[0].rack", "no racks"},
      {"duplicate rack", [](json& j) { j["networks"][0]["racks"][1]["name"] = "r0"; },
       "networks[0].racks[1].name", "duplicate"},
      {"uplink and oversubscription", [](json& j) { j["networks"][0]["racks"][0]["oversubscription"] = 2; },
       "networks[0].racks[0].uplink", "either"},
      {"neither uplink nor oversubscription", [](json& j) { j["networks"][0]["racks"][0].erase("uplink"); },
       "networks[0].racks[0].uplink", "either"},
      {"oversubscription not positive", [](json& j) { j["networks"][0]["racks"][1]["oversubscription"] = 0; },
       "networks[0].racks[1].oversubscription", "> 0"},
      {"empty rack", [](json& j) { j["networks"][0]["racks"].push_back({{"name", "r2"}, {"uplink", "1Gb/s"}}); },
       "networks[0].racks[2].name", "no member"},
      {"backbone without bandwidth", [](json& j) { j["networks"][0]["backbone"].erase("bandwidth"); },
       "networks[0].backbone.bandwidth", "missing"},
      {"backbone key typo", [](json& j) { j["networks"][0]["backbone"]["bandwith"] = "1Gb/s"; },
       "networks[0].backbone.bandwith", "unknown key"},
  };
  expect_errors(racked, cases);
}

TEST(PlatformLoader, InvalidJsonReportsLineAndColumn) {
  expect_error("{\n  \"name\": \"x\",\n  \"nodes\": [,]\n}", "", "line 3");
  expect_error("", "", "invalid JSON");
  expect_error("[1, 2]", "(top level)", "object");
}

TEST(PlatformLoader, DuplicateJsonKeysAreRejected) {
  std::string text = base().dump();
  // A second definition of node type "N" would silently replace the first.
  const std::string n = "\"N\":";
  const auto pos = text.find(n);
  ASSERT_NE(pos, std::string::npos);
  text.insert(pos, "\"N\":{},");
  expect_error(text, "node_types.N", "duplicate key");
  expect_error(R"({"name": "a", "nodes": [{"name": "x", "name": "y"}]})", "nodes[].name", "duplicate key");
}

TEST(PlatformLoader, FixtureFilesFailWithTheirFileAndField) {
  const std::string dir = std::string(RAYLINE_TEST_DATA) + "/platforms/bad/";
  struct Case {
    const char* file;
    const char* field;
  };
  for (const Case& c : {Case{"invalid_json.json", ""}, Case{"unknown_memory.json", "node_types.A.compute[1].memory"},
                        Case{"bad_bandwidth.json", "node_types.A.channels[1].bandwidth"},
                        Case{"unreachable_gpu.json", "node_types.A.memory[2]"},
                        Case{"unknown_key.json", "networks[0].members[0].bandwith"}}) {
    SCOPED_TRACE(c.file);
    ASSERT_TRUE(std::filesystem::exists(dir + c.file));
    try {
      load_platform(dir + c.file);
      ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), dir + c.file);
      EXPECT_EQ(e.field(), c.field) << e.what();
    }
  }
}

TEST(PlatformLoader, MissingFile) {
  try {
    load_platform("/nonexistent/platform.json");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "/nonexistent/platform.json");
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos);
  }
}

// Every loader opens its file through open_input(): a folder given where a file belongs
// is named as a folder (std::ifstream opens one and reads nothing, which the parsers used
// to report as "unexpected end of input"), and a missing file says why.
TEST(InputFiles, FoldersAndMissingFilesAreNamedByEveryLoader) {
  const std::string dir = ::testing::TempDir() + "rayline-input-folder.json";
  std::filesystem::create_directories(dir);
  const DeviceGraph g = load_platform(platform_path("paper-A.json"));
  const std::vector<std::pair<std::string, std::function<void(const std::string&)>>> loaders = {
      {"platform file", [](const std::string& p) { load_platform(p); }},
      {"job-set file", [&](const std::string& p) { load_job_set(p, g); }},
      {"scene profile", [](const std::string& p) { load_scene_profile(p); }},
      {"replay log", [](const std::string& p) { ReplayLog::load(p, nullptr); }},
      {"timing samples file", [&](const std::string& p) { read_timing_samples_csv(p, g); }}};
  for (const auto& [what, load] : loaders) {
    for (const std::string& path : {dir, std::string("/nonexistent-rayline/x.json")}) {
      try {
        load(path);
        ADD_FAILURE() << what << ": accepted " << path;
      } catch (const InputError& e) {
        EXPECT_EQ(e.file(), path) << what;
        const std::string msg = e.what();
        EXPECT_NE(msg.find(what), std::string::npos) << msg;
        EXPECT_NE(msg.find(path == dir ? "is a folder" : "No such file or directory"), std::string::npos) << msg;
      }
    }
  }
  std::filesystem::remove(dir);
}

}  // namespace

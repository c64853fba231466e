#include "render/engine/workstation.hpp"

#include <algorithm>
#include <cstdio>
#include <string>

#include "common/error.hpp"
#include "sched/io/platform_loader.hpp"

namespace rayline::engine {

namespace {
std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}
std::string us(double seconds) { return "\"" + num(seconds * 1e6) + "us\""; }
std::string bps(double bytes_per_s) { return "\"" + num(bytes_per_s) + "B/s\""; }
std::string bytes(Bytes b) { return "\"" + std::to_string(b) + "B\""; }
std::string timing(Time ri_setup, double ri_rate, Time si_setup, double si_rate) {
  return "\"timing\": {\n          \"RayIntersect\": {\"setup\": " + us(ri_setup) + ", \"rate\": {\"RayQueue\": " +
         bps(1.0 / ri_rate) + "}},\n          \"ShadowIntersect\": {\"setup\": " + us(si_setup) +
         ", \"rate\": {\"ShadowRayQueue\": " + bps(1.0 / si_rate) + "}}\n        }}";
}
}  // namespace

namespace {
// The node type "W" of a model: its memories, compute devices and channels.
std::string node_type_json(const WorkstationModel& m) {
  std::string s = "  \"node_types\": {\n    \"W\": {\n      \"memory\": [\n";
  s += "        {\"name\": \"disk\", \"kind\": \"disk\", \"capacity\": " + bytes(m.disk_capacity) + "},\n";
  s += "        {\"name\": \"ram\", \"kind\": \"host\", \"capacity\": " + bytes(m.ram_capacity) + "}";
  for (std::size_t i = 0; i < m.gpus.size(); ++i)
    s += ",\n        {\"name\": \"gpu" + std::to_string(i) + "mem\", \"kind\": \"gpu\", \"capacity\": " +
         bytes(m.gpus[i].memory) + "}";
  s += "\n      ],\n      \"compute\": [\n        {\"name\": \"cpu\", \"kind\": \"cpu\", \"count\": " +
       std::to_string(m.threads) + ", \"memory\": \"ram\", " +
       timing(m.intersect_setup, m.intersect_rate, m.shadow_setup, m.shadow_rate);
  for (std::size_t i = 0; i < m.gpus.size(); ++i) {
    const GpuModel& gm = m.gpus[i];
    s += ",\n        {\"name\": \"gpu" + std::to_string(i) + "\", \"kind\": \"gpu\", \"memory\": \"gpu" +
         std::to_string(i) + "mem\", " + timing(gm.intersect_setup, gm.intersect_rate, gm.shadow_setup, gm.shadow_rate);
  }
  s += "\n      ],\n";
  // One disk->RAM channel per loader ("disk", "disk2", ...), each a lane of T-jobs (its own
  // loader thread in LocalExecutor), so that one block's BVH builds while another's does.
  s += "      \"channels\": [";
  for (int k = 0; k < std::max(1, m.loaders); ++k)
    s += std::string(k ? "," : "") + "\n        {\"name\": \"disk" + (k ? std::to_string(k + 1) : "") +
         "\", \"kind\": \"disk\", \"between\": [\"disk\", \"ram\"], \"duplex\": \"half\", \"latency\": " +
         us(m.disk_latency) + ", \"bandwidth\": " + bps(m.disk_bandwidth) +
         (m.disk_cpu_contention > 0 || m.disk_exec_contention > 0
              ? ", \"cpu_contention\": {\"transfer\": " + num(m.disk_cpu_contention) + ", \"exec\": " +
                    num(m.disk_exec_contention) + "}"
              : std::string()) +
         "}";
  for (std::size_t i = 0; i < m.gpus.size(); ++i)
    s += ",\n        {\"name\": \"pcie" + std::to_string(i) + "\", \"kind\": \"pcie\", \"between\": [\"ram\", \"gpu" +
         std::to_string(i) + "mem\"], \"duplex\": \"full\", \"latency\": " + us(m.gpus[i].pcie_latency) +
         ", \"bandwidth\": " + bps(m.gpus[i].pcie_bandwidth) + "}";
  s += "\n      ]\n    }\n  },\n";
  return s;
}
std::string loop_json(const WorkstationModel& m) {
  std::string s;
  if (m.loop.modelled() || m.loop.wake > 0 || m.loop.per_camera_ray > 0 || m.loop.pickup > 0)
    s += ",\n  \"control_loop\": {\"per_job\": " + us(m.loop.per_job) + ", \"per_exec_second\": " +
         num(m.loop.per_exec_second) + (m.loop.wake > 0 ? ", \"wake\": " + us(m.loop.wake) : std::string()) +
         (m.loop.per_camera_ray > 0 ? ", \"per_camera_ray\": " + us(m.loop.per_camera_ray) : std::string()) +
         (m.loop.pickup > 0 ? ", \"pickup\": " + us(m.loop.pickup) : std::string()) + "}";
  return s;
}
}  // namespace

std::string workstation_json(const WorkstationModel& m, const std::string& description) {
  std::string s = "{\n  \"name\": \"workstation\",\n  \"description\": \"" + description + "\",\n";
  s += node_type_json(m) + "  \"nodes\": [{\"name\": \"W\", \"type\": \"W\"}]" + loop_json(m) + "\n}\n";
  return s;
}

LanModel lan_for_plan(LanModel network, const WorkstationModel& m) {
  const auto series = [&](double bw) { return 1.0 / (1.0 / bw + 1.0 / m.disk_bandwidth); };
  network.bandwidth = series(network.bandwidth);
  for (double& b : network.nic) b = series(b);
  return network;
}

std::string cluster_json(const WorkstationModel& m, int nodes, const LanModel& lan, const std::string& description) {
  std::string s = "{\n  \"name\": \"cluster\",\n  \"description\": \"" + description + "\",\n";
  s += node_type_json(m) + "  \"nodes\": [";
  std::string members;
  for (int r = 0; r < nodes; ++r) {
    s += std::string(r ? ", " : "") + "{\"name\": \"R" + std::to_string(r) + "\", \"type\": \"W\"}";
    members += std::string(r ? ", " : "") + "{\"node\": \"R" + std::to_string(r) + "\"" +
               (std::size_t(r) < lan.nic.size() ? ", \"bandwidth\": " + bps(lan.nic[std::size_t(r)]) : std::string()) + "}";
  }
  s += "]";
  if (nodes > 1)
    s += ",\n  \"networks\": [{\"name\": \"lan\", \"kind\": \"lan\", \"latency\": " + us(lan.latency) +
         ", \"bandwidth\": " + bps(lan.bandwidth) + ", \"duplex\": \"full\",\n    \"members\": [" + members + "]}]";
  s += loop_json(m) + "\n}\n";
  return s;
}

DeviceGraph make_workstation(const WorkstationModel& m, const std::string& platform) {
  const bool defaults = platform.empty() || platform == "auto";
  return parse_platform(workstation_json(m, defaults ? std::string("this machine (defaults)") : "from " + platform),
                        defaults ? std::string("<auto platform>") : platform);
}

WorkstationModel workstation_model(const std::string& platform) {
  return platform.empty() || platform == "auto" ? WorkstationModel{} : load_workstation_model(platform);
}

void set_gpu(WorkstationModel& m, Bytes memory) {
  if (memory == 0) {
    m.gpus.clear();
    return;
  }
  if (m.gpus.empty()) m.gpus.emplace_back();  // uncalibrated: the defaults seed the plan
  m.gpus.resize(1);
  m.gpus[0].memory = memory;
}

WorkstationModel load_workstation_model(const std::string& path) { return load_node_model(path, nullptr, nullptr); }

WorkstationModel load_node_model(const std::string& path, int* nodes, LanModel* lan) {
  DeviceGraph g = load_platform(path);
  MemId disk = kNone, ram = kNone;
  for (std::size_t i = 0; i < g.memories.size(); ++i) {
    if (g.memories[i].node != 0) continue;
    if (g.memories[i].kind == MemoryKind::Disk && disk == kNone) disk = static_cast<MemId>(i);
    if (g.memories[i].kind == MemoryKind::Host && ram == kNone) ram = static_cast<MemId>(i);
  }
  if (disk == kNone) throw InputError(path, "memory", "the renderer needs a memory device of kind disk");
  if (ram == kNone) throw InputError(path, "memory", "the renderer needs a memory device of kind host");
  if (!nodes && g.nodes.size() != 1) throw InputError(path, "nodes", "the renderer drives one machine: exactly one node");
  if (nodes) {  // a cluster: every node like the first, one LAN between them (its first channel)
    *nodes = int(g.nodes.size());
    for (const Channel& c : g.channels)
      if (c.network != kNone) {
        lan->latency = c.latency;
        lan->bandwidth = c.bandwidth;
        break;
      }
  }
  const Channel* dc = nullptr;
  int loaders = 0;
  for (const Channel& c : g.channels)
    if (c.from == disk && c.to == ram) {
      if (!dc) dc = &c;
      ++loaders;
    }
  if (!dc) throw InputError(path, "channels", "no channel from the disk to host memory");
  const JobTypeId ri = g.job_type("RayIntersect"), si = g.job_type("ShadowIntersect");
  WorkstationModel m;
  m.threads = 0;
  m.ram_capacity = g.memories[ram].capacity;
  m.disk_capacity = g.memories[disk].capacity;
  m.loaders = loaders;
  m.disk_latency = dc->latency;
  m.disk_bandwidth = dc->bandwidth;
  m.disk_cpu_contention = dc->cpu_contention;
  m.disk_exec_contention = dc->exec_contention;
  m.loop = g.loop;
  // Both job types with a rate on their ray queue, per compute device model.
  auto coefficients = [&](DeviceId d, Time& ri_setup, double& ri_rate, Time& si_setup, double& si_rate) {
    const ComputeDevice& c = g.computes[d];
    if (ri == kNone || si == kNone || !g.timing.supports(d, ri) || !g.timing.supports(d, si))
      throw InputError(path, "compute." + c.model + ".timing", "needs RayIntersect and ShadowIntersect");
    const ExecCoefficients& a = g.timing.at(d, ri);
    const ExecCoefficients& b = g.timing.at(d, si);
    ri_setup = a.setup;
    ri_rate = a.rate[static_cast<int>(DataKind::RayQueue)];
    si_setup = b.setup;
    si_rate = b.rate[static_cast<int>(DataKind::ShadowRayQueue)];
    if (!(ri_rate > 0) || !(si_rate > 0))
      throw InputError(path, "compute." + c.model + ".timing", "needs a RayQueue / ShadowRayQueue rate");
  };
  bool cpu = false;
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const ComputeDevice& c = g.computes[d];
    if (c.node != 0) continue;
    if (c.kind == ComputeKind::Cpu) {
      if (c.memory != ram) throw InputError(path, "compute." + c.model + ".memory", "CPU devices work from host memory");
      if (!cpu) coefficients(DeviceId(d), m.intersect_setup, m.intersect_rate, m.shadow_setup, m.shadow_rate);
      cpu = true;
      ++m.threads;
      continue;
    }
    // A GPU: its own memory device, linked to RAM both ways.
    GpuModel gm;
    coefficients(DeviceId(d), gm.intersect_setup, gm.intersect_rate, gm.shadow_setup, gm.shadow_rate);
    const MemId mem = c.memory;
    if (g.memories[mem].kind != MemoryKind::Gpu)
      throw InputError(path, "compute." + c.model + ".memory", "a GPU works from a memory device of kind gpu");
    gm.memory = g.memories[mem].capacity;
    const Channel* up = nullptr;
    for (const Channel& ch : g.channels)
      if (ch.from == ram && ch.to == mem) up = &ch;
    bool down = false;
    for (const Channel& ch : g.channels) down = down || (ch.from == mem && ch.to == ram);
    if (!up || !down)
      throw InputError(path, "channels", "GPU memory '" + g.memories[mem].name + "' needs channels to and from host memory");
    gm.pcie_latency = up->latency;
    gm.pcie_bandwidth = up->bandwidth;
    m.gpus.push_back(gm);
  }
  if (!cpu) throw InputError(path, "compute", "no CPU compute device on host memory");
  return m;
}

}  // namespace rayline::engine

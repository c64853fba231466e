#include "render/engine/workstation.hpp"

#include <cstdio>
#include <string>

#include "sched/error.hpp"
#include "sched/platform_loader.hpp"

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
}  // namespace

std::string workstation_json(const WorkstationModel& m, const std::string& description) {
  std::string s = "{\n  \"name\": \"workstation\",\n  \"description\": \"" + description + "\",\n";
  s += "  \"node_types\": {\n    \"W\": {\n      \"memory\": [\n";
  s += "        {\"name\": \"disk\", \"kind\": \"disk\", \"capacity\": " + bytes(m.disk_capacity) + "},\n";
  s += "        {\"name\": \"ram\", \"kind\": \"host\", \"capacity\": " + bytes(m.ram_capacity) + "}\n      ],\n";
  s += "      \"compute\": [\n        {\"name\": \"cpu\", \"kind\": \"cpu\", \"count\": " + std::to_string(m.threads) +
       ", \"memory\": \"ram\", \"timing\": {\n";
  s += "          \"RayIntersect\": {\"setup\": " + us(m.intersect_setup) + ", \"rate\": {\"RayQueue\": " +
       bps(1.0 / m.intersect_rate) + "}},\n";
  s += "          \"ShadowIntersect\": {\"setup\": " + us(m.shadow_setup) + ", \"rate\": {\"ShadowRayQueue\": " +
       bps(1.0 / m.shadow_rate) + "}}\n        }}\n      ],\n";
  s += "      \"channels\": [\n        {\"name\": \"disk\", \"kind\": \"disk\", \"between\": [\"disk\", \"ram\"], "
       "\"duplex\": \"half\", \"latency\": " +
       us(m.disk_latency) + ", \"bandwidth\": " + bps(m.disk_bandwidth) + "}\n      ]\n";
  s += "    }\n  },\n  \"nodes\": [{\"name\": \"W\", \"type\": \"W\"}]\n}\n";
  return s;
}

DeviceGraph make_workstation(const WorkstationModel& m) {
  return parse_platform(workstation_json(m, "this machine (defaults)"), "<auto platform>");
}

DeviceGraph load_workstation(const std::string& path, int threads, Bytes ram_capacity) {
  DeviceGraph g = load_platform(path);
  MemId disk = kNone, ram = kNone;
  for (std::size_t i = 0; i < g.memories.size(); ++i) {
    if (g.memories[i].kind == MemoryKind::Disk && disk == kNone) disk = static_cast<MemId>(i);
    if (g.memories[i].kind == MemoryKind::Host && ram == kNone) ram = static_cast<MemId>(i);
  }
  if (disk == kNone) throw InputError(path, "memory", "the renderer needs a memory device of kind disk");
  if (ram == kNone) throw InputError(path, "memory", "the renderer needs a memory device of kind host");
  bool channel = false;
  for (const Channel& c : g.channels) channel = channel || (c.from == disk && c.to == ram);
  if (!channel) throw InputError(path, "channels", "no channel from the disk to host memory");
  const JobTypeId ri = g.job_type("RayIntersect"), si = g.job_type("ShadowIntersect");
  const ComputeDevice* cpu = nullptr;
  DeviceId cpu_id = kNone;
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    if (g.computes[d].kind == ComputeKind::Cpu && g.computes[d].memory == ram) {
      cpu = &g.computes[d];
      cpu_id = static_cast<DeviceId>(d);
      break;
    }
  if (!cpu) throw InputError(path, "compute", "no CPU compute device on host memory");
  if (ri == kNone || si == kNone || !g.timing.supports(cpu_id, ri) || !g.timing.supports(cpu_id, si))
    throw InputError(path, "compute." + cpu->model + ".timing", "needs RayIntersect and ShadowIntersect");
  if (threads <= 0 && ram_capacity == 0) return g;
  // Rebuild from the calibrated numbers with the requested thread count / capacity.
  WorkstationModel m;
  const Channel* dc = nullptr;
  for (const Channel& c : g.channels)
    if (c.from == disk && c.to == ram) dc = &c;
  m.threads = threads > 0 ? threads : static_cast<int>(g.computes_on(ram).size());
  m.ram_capacity = ram_capacity > 0 ? ram_capacity : g.memories[ram].capacity;
  m.disk_capacity = g.memories[disk].capacity;
  m.disk_latency = dc->latency;
  m.disk_bandwidth = dc->bandwidth;
  const ExecCoefficients& a = g.timing.at(cpu_id, ri);
  const ExecCoefficients& b = g.timing.at(cpu_id, si);
  m.intersect_setup = a.setup;
  m.intersect_rate = a.rate[static_cast<int>(DataKind::RayQueue)];
  m.shadow_setup = b.setup;
  m.shadow_rate = b.rate[static_cast<int>(DataKind::ShadowRayQueue)];
  if (!(m.intersect_rate > 0) || !(m.shadow_rate > 0))
    throw InputError(path, "compute." + cpu->model + ".timing", "needs a RayQueue / ShadowRayQueue rate");
  return parse_platform(workstation_json(m, "from " + path), path);
}

}  // namespace rayline::engine

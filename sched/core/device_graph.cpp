#include "sched/core/device_graph.hpp"

#include <algorithm>
#include <queue>

#include "common/error.hpp"

namespace rayline {

std::string_view to_string(MemoryKind k) {
  switch (k) {
    case MemoryKind::Disk: return "disk";
    case MemoryKind::Host: return "host";
    case MemoryKind::Gpu: return "gpu";
  }
  return "?";
}

std::string_view to_string(ComputeKind k) { return k == ComputeKind::Cpu ? "cpu" : "gpu"; }

void DeviceGraph::finalize() {
  const auto nm = memories.size();
  out_.assign(nm, {});
  in_.assign(nm, {});
  attached_.assign(nm, {});
  for (std::size_t i = 0; i < channels.size(); ++i) {
    const Channel& c = channels[i];
    const std::string field = "channels[" + c.name + "]";
    if (c.from < 0 || c.from >= static_cast<MemId>(nm) || c.to < 0 || c.to >= static_cast<MemId>(nm))
      throw InputError(source_file, field, "channel endpoint is not a memory device");
    if (c.from == c.to) throw InputError(source_file, field, "channel connects a memory device to itself");
    if (!(c.bandwidth > 0)) throw InputError(source_file, field + ".bandwidth", "must be > 0");
    if (!(c.latency >= 0)) throw InputError(source_file, field + ".latency", "must be >= 0");
    if (c.resources.empty()) throw InputError(source_file, field, "channel uses no resource");
    for (ResourceId r : c.resources)
      if (r < 0 || r >= static_cast<ResourceId>(resources.size()))
        throw InputError(source_file, field, "unknown resource");
    if (c.network != kNone && (c.network < 0 || c.network >= static_cast<std::int32_t>(networks.size())))
      throw InputError(source_file, field + ".network", "unknown network");
    out_[c.from].push_back(static_cast<ChannelId>(i));
    in_[c.to].push_back(static_cast<ChannelId>(i));
  }
  const auto resource_ok = [&](ResourceId r) { return r >= 0 && r < static_cast<ResourceId>(resources.size()); };
  for (const Network& n : networks) {
    const std::string field = "networks[" + n.name + "]";
    if (n.backbone != kNone && !resource_ok(n.backbone)) throw InputError(source_file, field + ".backbone", "unknown resource");
    for (const Rack& r : n.racks)
      if (!resource_ok(r.up) || !resource_ok(r.down))
        throw InputError(source_file, field + ".racks[" + r.name + "]", "unknown resource");
    for (const NetworkMember& m : n.members)
      if (m.memory < 0 || m.memory >= static_cast<MemId>(nm) || !resource_ok(m.out) || !resource_ok(m.in) ||
          (m.rack != kNone && (m.rack < 0 || m.rack >= static_cast<std::int32_t>(n.racks.size()))))
        throw InputError(source_file, field + ".members", "a member names an unknown memory device, resource or rack");
  }
  for (std::size_t d = 0; d < computes.size(); ++d) {
    const ComputeDevice& cd = computes[d];
    if (cd.memory < 0 || cd.memory >= static_cast<MemId>(nm))
      throw InputError(source_file, "compute[" + cd.name + "].memory", "compute device has no memory device");
    attached_[cd.memory].push_back(static_cast<DeviceId>(d));
  }
  if (timing.devices() != static_cast<int>(computes.size()) ||
      timing.job_types() != static_cast<int>(job_types.size()))
    timing.resize(static_cast<int>(computes.size()), static_cast<int>(job_types.size()));
}

std::vector<ResourceId> Network::route(std::size_t a, std::size_t b) const {
  const std::int32_t ra = members[a].rack, rb = members[b].rack;  // (both kNone without racks)
  std::vector<ResourceId> r{members[a].out};
  if (ra != rb) r.push_back(racks[static_cast<std::size_t>(ra)].up);
  if (crosses_backbone(a, b)) r.push_back(backbone);
  if (ra != rb) r.push_back(racks[static_cast<std::size_t>(rb)].down);
  r.push_back(members[b].in);
  return r;
}

JobTypeId DeviceGraph::job_type(std::string_view n) const {
  for (std::size_t i = 0; i < job_types.size(); ++i)
    if (job_types[i] == n) return static_cast<JobTypeId>(i);
  return kNone;
}

JobTypeId DeviceGraph::add_job_type(std::string_view n) {
  if (JobTypeId j = job_type(n); j != kNone) return j;
  job_types.emplace_back(n);
  timing.resize(static_cast<int>(computes.size()), static_cast<int>(job_types.size()));
  return static_cast<JobTypeId>(job_types.size() - 1);
}

template <class V>
static std::int32_t find_by_name(const V& v, std::string_view n) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i].name == n) return static_cast<std::int32_t>(i);
  return kNone;
}
MemId DeviceGraph::find_memory(std::string_view n) const { return find_by_name(memories, n); }
DeviceId DeviceGraph::find_compute(std::string_view n) const { return find_by_name(computes, n); }
NodeId DeviceGraph::find_node(std::string_view n) const { return find_by_name(nodes, n); }

std::vector<Time> DeviceGraph::shortest_fetch_times(const std::vector<MemId>& sources, Bytes bytes) const {
  std::vector<Time> dist(memories.size(), kNever);
  using Item = std::pair<Time, MemId>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
  for (MemId s : sources) {
    dist[s] = 0;
    heap.emplace(0.0, s);
  }
  while (!heap.empty()) {
    auto [t, m] = heap.top();
    heap.pop();
    if (t > dist[m]) continue;
    for (ChannelId c : out_[m]) {
      const Time nt = t + transfer_time(c, bytes);
      const MemId q = channels[c].to;
      if (nt < dist[q]) {
        dist[q] = nt;
        heap.emplace(nt, q);
      }
    }
  }
  return dist;
}

}  // namespace rayline

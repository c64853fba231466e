#include "sched/runtime/fault.hpp"

#include <stdexcept>

#include "common/error.hpp"
#include "common/units.hpp"

namespace rayline {

Fault parse_fault(std::string_view spec, const DeviceGraph& g, const std::string& flag) {
  Fault f;
  f.what = std::string(spec);
  const auto at = spec.rfind('@');
  if (at == std::string_view::npos || at == 0)
    throw InputError(flag, f.what, "expected DEVICE@TIME, e.g. B3@10s (a node, memory or compute device, and when it fails)");
  const std::string_view name = spec.substr(0, at);
  try {
    f.at = units::parse_duration(spec.substr(at + 1));
  } catch (const std::invalid_argument& e) {
    throw InputError(flag, f.what, std::string("TIME: ") + e.what() + " (units: ns, us, ms, s, min, h)");
  }
  if (const NodeId n = g.find_node(name); n != kNone) {
    const Node& node = g.nodes[static_cast<std::size_t>(n)];
    f.memories = node.memories;
    f.computes = node.computes;
  } else if (const MemId m = g.find_memory(name); m != kNone) {
    f.memories.push_back(m);
    f.computes = g.computes_on(m);
  } else if (const DeviceId d = g.find_compute(name); d != kNone) {
    f.computes.push_back(d);
  } else {
    std::string nodes;
    for (const Node& node : g.nodes) nodes += (nodes.empty() ? "" : ", ") + node.name;
    throw InputError(flag, f.what,
                     "no node, memory or compute device '" + std::string(name) + "' on platform " + g.name +
                         " (nodes: " + nodes + "; `rayline platform` lists every device)");
  }
  return f;
}

}  // namespace rayline

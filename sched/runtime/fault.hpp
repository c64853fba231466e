// Faults (docs/faults.md): a device lost mid-run, as a user asks for it with
// `--fail DEVICE@TIME`. DEVICE names a node (all its devices and data), a memory device
// (its data and the compute devices attached to it) or a compute device; TIME is a
// duration with its unit ("10s", "250ms").
#pragma once
#include <string>
#include <string_view>
#include <vector>

#include "sched/core/device_graph.hpp"

namespace rayline {

struct Fault {
  Time at = 0;
  std::string what;                // as written ("B3@10s"), for messages
  std::vector<DeviceId> computes;  // compute devices lost
  std::vector<MemId> memories;     // memory devices lost, with the data on them
};

// Throws InputError naming `flag` (the option, e.g. "--fail") when the spec is malformed
// or names no device of `g`.
Fault parse_fault(std::string_view spec, const DeviceGraph& g, const std::string& flag = "--fail");

}  // namespace rayline

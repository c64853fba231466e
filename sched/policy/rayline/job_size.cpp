#include "sched/policy/rayline/job_size.hpp"

#include <algorithm>
#include <limits>

namespace rayline {

std::vector<Bytes> device_sized_job_caps(const DeviceGraph& g, Time seconds) {
  const int types = g.timing.job_types();
  std::vector<Bytes> caps(static_cast<std::size_t>(std::max(0, types)), 0);
  if (seconds <= 0) return caps;
  for (JobTypeId t = 0; t < types; ++t) {
    // The fastest rate (least seconds per byte) over every device and non-scene input kind.
    double fastest = std::numeric_limits<double>::infinity();
    for (DeviceId d = 0; d < static_cast<DeviceId>(g.computes.size()); ++d) {
      if (!g.timing.supports(d, t)) continue;
      const ExecCoefficients& c = g.timing.at(d, t);
      for (std::size_t k = 0; k < c.rate.size(); ++k)
        if (static_cast<DataKind>(k) != DataKind::SceneData && c.rate[k] > 0) fastest = std::min(fastest, c.rate[k]);
    }
    if (fastest < std::numeric_limits<double>::infinity())
      caps[static_cast<std::size_t>(t)] = static_cast<Bytes>(seconds / fastest);
  }
  return caps;
}

}  // namespace rayline

#include "sched/timeline/utilisation.hpp"

#include <algorithm>

namespace rayline {

Utilisation compute_utilisation(const Schedule& s, Time t0, Time t1) {
  const DeviceGraph& g = s.graph();
  Utilisation u;
  u.span = std::max<Time>(0, t1 - t0);
  u.devices.resize(g.computes.size());
  auto clip = [&](Time a, Time b) { return std::max<Time>(0, std::min(b, t1) - std::max(a, t0)); };
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    DeviceTime& dt = u.devices[d];
    Time prev_end = t0;
    for (ActivityId id : s.device_timeline(static_cast<DeviceId>(d)).items) {
      const Activity& a = s.activity(id);
      if (a.cancelled) continue;  // withdrawn (Sec. 5.2): it never waited for data nor ran
      // Gap before this E-job: fetching while its inputs were still arriving, idle otherwise.
      const Time gap_end = std::max(prev_end, a.start);
      const Time fetch_until = std::clamp(a.data_ready, prev_end, gap_end);
      dt.fetching += clip(prev_end, fetch_until);
      dt.idle += clip(fetch_until, gap_end);
      const Time setup_end = std::min(a.end, a.start + a.setup);
      dt.setup += clip(a.start, setup_end);
      dt.busy += clip(setup_end, a.end);
      prev_end = std::max(prev_end, a.end);
    }
    dt.idle += clip(prev_end, t1);
  }
  u.resource_busy.assign(g.resources.size(), 0);
  u.resource_bytes.assign(g.resources.size(), 0);
  for (std::size_t r = 0; r < g.resources.size(); ++r)
    for (ActivityId id : s.resource_timeline(static_cast<ResourceId>(r)).items) {
      const Activity& a = s.activity(id);
      const Time c = clip(a.start, a.end);
      u.resource_busy[r] += c;
      if (a.end > a.start) u.resource_bytes[r] += static_cast<double>(a.bytes) * c / (a.end - a.start);
    }
  return u;
}

}  // namespace rayline

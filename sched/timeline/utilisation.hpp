// Per-device time split of Sec. 4.2 over [t0, t1]: busy (executing beyond setup), setup
// (T_SETUP, Eq. 2), fetching (idle while the next E-job waits for its T-jobs) and true
// idle (nothing scheduled). Per-resource busy share for channels.
#pragma once
#include <vector>

#include "sched/timeline/schedule.hpp"

namespace rayline {

struct DeviceTime {
  Time busy = 0, setup = 0, fetching = 0, idle = 0;
  double utilisation(Time span) const { return span > 0 ? (busy + setup) / span : 0; }
};

struct Utilisation {
  Time span = 0;
  std::vector<DeviceTime> devices;
  std::vector<Time> resource_busy;     // seconds some T-job occupied the resource
  std::vector<double> resource_bytes;  // bytes carried
};

// Uses each activity's current start/end (planned, projected or measured).
Utilisation compute_utilisation(const Schedule& s, Time t0, Time t1);

}  // namespace rayline

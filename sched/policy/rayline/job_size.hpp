// Rayline's rule 7, device-sized jobs (docs/rayline-policy.md): a queued ray job stops
// taking merged queues (Sec. 5.1) once it holds the ray bytes the platform's fastest
// device for its job type traces in `seconds`, so that a wave of a million rays is not one
// job that holds a CPU thread for many seconds while the GPU idles, and each device gets
// jobs about its own planning step long. A queue larger than the cap still forms one job.
#pragma once
#include <vector>

#include "sched/core/device_graph.hpp"

namespace rayline {

// Per job type (by JobTypeId): the most bytes of non-scene input (ray queues, hit records)
// one job may hold, seconds / the smallest T_RATE (Eq. 2) any compute device has for such
// an input of that type; 0 where no device rates one (no cap) or seconds <= 0.
std::vector<Bytes> device_sized_job_caps(const DeviceGraph& g, Time seconds);

}  // namespace rayline

// CSV reader for measured E-job durations, the input of TimingModel::fit() (Sec. 6: T_SETUP
// and T_RATE "fitted using the least square method" from a sample run).
//
// Format: a header line, then one sample per line:
//   device,job_type,SceneData,RayQueue,ShadowRayQueue,Framebuffer,Generic,duration_s
// device   - a compute device name of the DeviceGraph ("A0.gpu0")
// job_type - a job type name of the DeviceGraph ("RayIntersect")
// <kind>   - total input bytes of that DataKind (non-negative integer; 0 = no such input)
// duration_s - measured execution time in seconds (finite, >= 0)
// Blank lines and lines starting with '#' are ignored; fields are trimmed of spaces/tabs
// (and a trailing '\r'); quoting is not supported. Errors throw InputError(path,
// "line N column NAME", message); a missing header or wrong column set uses "line 1".
#pragma once
#include <string>
#include <vector>

#include "sched/core/device_graph.hpp"
#include "sched/core/timing_model.hpp"

namespace rayline {

std::vector<TimingSample> read_timing_samples_csv(const std::string& path, const DeviceGraph& g);

}  // namespace rayline

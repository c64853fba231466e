// Outputs users expect (DESIGN.md): timelines as Chrome trace JSON (opens in Perfetto;
// one process per node, one track per compute device and per channel resource, E-jobs and
// T-jobs on separate tracks, planned and actual intervals as separate categories), and a
// per-job CSV (job, type, device, planned and actual start/end, bytes).
#pragma once
#include <string>

#include "schedule.hpp"

namespace rayline {

std::string chrome_trace_json(const Schedule& s, bool include_actual);
std::string jobs_csv(const Schedule& s);

}  // namespace rayline

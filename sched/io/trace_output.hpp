// Outputs users expect (docs/architecture.md): timelines as Chrome trace JSON (opens in Perfetto;
// one process per node, one track per compute device and per channel resource, E-jobs and
// T-jobs on separate tracks, planned and actual intervals as separate categories), and a
// per-job CSV (job, type, device, planned and actual start/end, bytes).
#pragma once
#include <iosfwd>
#include <string>

#include "sched/timeline/schedule.hpp"

namespace rayline {

// Streamed to `out` as they are formatted (a long simulation's outputs are larger than the
// schedule they describe); the string forms are for small plans and tests.
void write_chrome_trace(const Schedule& s, bool include_actual, std::ostream& out);
void write_jobs_csv(const Schedule& s, std::ostream& out);
std::string chrome_trace_json(const Schedule& s, bool include_actual);
std::string jobs_csv(const Schedule& s);

}  // namespace rayline

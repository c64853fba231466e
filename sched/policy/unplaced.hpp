// Why a queued job can be placed on no device at all: the runtime loop's "stalled" case
// (runtime_loop.hpp), told to the user instead of "capacity or no path". Only static
// reasons, the platform's and the job's, none that depend on what else is planned.
#pragma once
#include <string>

#include "sched/core/types.hpp"

namespace rayline {

class JobPool;
class Schedule;

// A sentence naming the job type, block, memory device or size that rules job j out, for
// the device that comes closest. Empty when some device has no static obstacle (room
// held by the blocks of planned jobs, say).
std::string why_unplaceable(JobId j, const JobPool& pool, const Schedule& s);

// The first queued job (queue order) that why_unplaceable rules out; kNone when none is.
JobId first_unplaceable(const JobPool& pool, const Schedule& s);

// "N job(s) could not be placed on any device; job 'x': <why>", x being first_unplaceable
// (else the first queued job, held back by what else is planned).
std::string unplaced_summary(const JobPool& pool, const Schedule& s);

}  // namespace rayline

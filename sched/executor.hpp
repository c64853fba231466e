// The Executor seam (DESIGN.md, control loop): the only engine-specific piece the runtime
// loop sees. It runs each timeline in order, waits for each activity's dependencies, and
// reports started / finished (measured times) / failed. sim/ implements it with SimGrid
// activities started from maestro; render/ with worker threads and file reads; this
// project's tests with ExactExecutor (plans run exactly as predicted, or perturbed).
#pragma once
#include <vector>

#include "schedule.hpp"

namespace rayline {

struct ExecutorEvent {
  enum class Type : std::uint8_t { Started, Finished, Failed };
  Type type;
  ActivityId activity;
  Time time;
};

class Executor {
 public:
  virtual ~Executor() = default;
  // Hand over a newly committed activity (called in commit order).
  virtual void dispatch(ActivityId id, const Activity& a) = 0;
  // Advance until at least one event happened (appended to `out`); false when nothing is
  // in flight and nothing can happen.
  virtual bool advance(std::vector<ExecutorEvent>& out) = 0;
  virtual Time now() const = 0;
};

}  // namespace rayline

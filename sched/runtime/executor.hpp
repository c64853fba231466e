// The Executor seam (docs/architecture.md, control loop): the only engine-specific piece the runtime
// loop sees. It runs each timeline in order, waits for each activity's dependencies, and
// reports started / finished (measured times) / failed. sim/ implements it with SimGrid
// activities started from maestro; render/ with worker threads and file reads; this
// project's tests with ExactExecutor (plans run exactly as predicted, or perturbed).
#pragma once
#include <functional>
#include <vector>

#include "sched/timeline/schedule.hpp"

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

  // Push mode, for engines that cannot hand control back at the next event (SimGrid 3.32
  // runs to completion): the executor calls `sink` from inside its own event processing,
  // at the simulated instant of the events, and the sink may dispatch new activities.
  // run_push() returns when nothing is in flight any more, or at `until`.
  using Sink = std::function<void(std::vector<ExecutorEvent>&)>;
  virtual bool supports_push() const { return false; }
  virtual void run_push(const Sink& /*sink*/, Time /*until*/) {}
};

}  // namespace rayline

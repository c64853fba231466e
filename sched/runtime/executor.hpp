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
  virtual Time now() const = 0;

  // Runs what was dispatched, handing each batch of events to `sink` at the instant they
  // happened; the sink may dispatch new activities (the loop re-plans there, Sec. 4.2).
  // Returns when nothing is in flight any more, or once the clock reached `until`.
  // Push is the general form: an engine that owns its event loop (SimGrid 3.32 runs to
  // completion) cannot hand control back per event, while one that can stop after each
  // batch runs as run_in_steps() below.
  using Sink = std::function<void(std::vector<ExecutorEvent>&)>;
  virtual void run(const Sink& sink, Time until) = 0;

 protected:
  // run() for an engine that stops after each batch: `step` appends the next batch (false
  // when nothing is in flight and nothing can happen). It steps while the clock is before
  // `until`, so the batch that reaches past `until` is still delivered.
  template <class Step>
  void run_in_steps(Step&& step, const Sink& sink, Time until) {
    std::vector<ExecutorEvent> events;
    while (now() < until) {
      events.clear();
      if (!step(events)) return;
      sink(events);
    }
  }
};

}  // namespace rayline

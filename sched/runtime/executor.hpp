// The Executor seam (docs/architecture.md, control loop): the only engine-specific piece the runtime
// loop sees. It runs each timeline in order, waits for each activity's dependencies, and
// reports started / finished (measured times) / failed. sim/ implements it with SimGrid
// activities started from maestro; render/ with worker threads and file reads; this
// project's tests with ExactExecutor (plans run exactly as predicted, or perturbed).
#pragma once
#include <exception>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "sched/timeline/schedule.hpp"

namespace rayline {

struct ExecutorEvent {
  enum class Type : std::uint8_t { Started, Finished, Failed };
  Type type;
  ActivityId activity;
  Time time;
};

// Thrown by an engine's work for a failure the run recovers from by re-planning (an I/O
// error or a checksum mismatch reading a block): the activity is reported Failed and the
// engine goes on. Any other exception ends the run.
class ActivityError : public std::runtime_error {
 public:
  // `cause`: the error itself (e.g. an InputError naming the block file), rethrown when the
  // retries are used up so the run ends as that error would have ended it.
  explicit ActivityError(const std::string& what, std::exception_ptr cause = nullptr)
      : std::runtime_error(what), cause_(std::move(cause)) {}
  std::exception_ptr cause() const { return cause_; }

 private:
  std::exception_ptr cause_;
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

  // ---- faults (docs/faults.md) -------------------------------------------------------
  // Deliver a batch (possibly empty) at time t: the loop takes control then, to apply a
  // fault at its time. A wake alone does not keep a run going (with nothing in flight
  // there is nothing a fault could take); an engine may still deliver it then.
  virtual void wake_at(Time t) = 0;
  // The compute devices and channels given are lost from now on: nothing more starts on
  // them. What runs there now either stops now, reported as Failed in `events` (simulated
  // engines: a host turned off), or, where work cannot be stopped part-way (a renderer
  // thread), ends as it would; `events` also receives whatever else ended meanwhile.
  virtual void halt(const std::vector<DeviceId>& computes, const std::vector<ChannelId>& channels,
                    std::vector<ExecutorEvent>& events) = 0;
  // Withdraws activities that have not started (Schedule::fail aborted them): they never
  // run and report nothing, and count as ended for their timeline successors.
  virtual void abort(const std::vector<ActivityId>& ids) = 0;
  // Why an activity was reported Failed (an I/O error reading a block), if the engine knows.
  virtual std::string why_failed(ActivityId) const { return {}; }
  // The error behind an activity reported Failed (ActivityError::cause), if any.
  virtual std::exception_ptr cause_of(ActivityId) const { return nullptr; }
  // The engine gave up after an error that is not an ActivityError: what it reports
  // Failed from then on is not recovered, the run just drains.
  virtual bool gave_up() const { return false; }

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

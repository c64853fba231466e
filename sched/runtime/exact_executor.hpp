// ExactExecutor: an in-process discrete-event executor that runs a plan exactly as the
// timing model predicts (duration = Activity::duration), honouring dependencies and the
// order of every timeline. `perturb` lets tests make reality differ from the plan.
// A withdrawn activity (Schedule::cancel) runs for 0 s — also one the loop withdrew in the
// very batch that reported its start (it started at that instant; it ends then too).
#pragma once
#include <functional>
#include <queue>
#include <vector>

#include "sched/runtime/executor.hpp"

namespace rayline {

class ExactExecutor final : public Executor {
 public:
  explicit ExactExecutor(const Schedule& schedule) : schedule_(schedule) {}
  void dispatch(ActivityId id, const Activity& a) override;
  Time now() const override { return now_; }
  void run(const Sink& sink, Time until) override;
  void wake_at(Time t) override { wakes_.push(t); }
  // Running activities on lost devices stop now (Failed), as on a simulated host turned off.
  void halt(const std::vector<DeviceId>& computes, const std::vector<ChannelId>& channels,
            std::vector<ExecutorEvent>& events) override;
  void abort(const std::vector<ActivityId>& ids) override;
  // One step: the next batch of events, appended to `out`; false when nothing is in
  // flight and nothing can happen (tests step the executor by hand).
  bool advance(std::vector<ExecutorEvent>& out);
  // Actual duration from the predicted one (default: identical).
  std::function<Time(ActivityId, const Activity&)> perturb;

 private:
  void try_start(ActivityId id);
  const Schedule& schedule_;
  Time now_ = 0;
  // placeholder: aborted before it started (Schedule::fail): ends, silently and at once,
  // when its timeline predecessors have.
  struct State { bool dispatched = false, started = false, done = false, placeholder = false; Time start = 0, end = 0; };
  std::vector<State> st_;
  std::vector<std::vector<ActivityId>> waiters_;  // dependency -> activities to re-check
  using Ev = std::pair<Time, ActivityId>;
  std::priority_queue<Ev, std::vector<Ev>, std::greater<>> running_;
  std::vector<ExecutorEvent> pending_starts_;
  std::vector<ActivityId> reported_starts_;  // started in the batch handed out last
  std::priority_queue<Time, std::vector<Time>, std::greater<>> wakes_;
  void finish(ActivityId id);  // done: wake what waited for it
  std::vector<ActivityId> halted_;  // stopped by halt(), woken by the abort() that follows
};

}  // namespace rayline

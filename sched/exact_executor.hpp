// ExactExecutor: an in-process discrete-event executor that runs a plan exactly as the
// timing model predicts (duration = Activity::duration), honouring dependencies and the
// order of every timeline. `perturb` lets tests make reality differ from the plan.
#pragma once
#include <functional>
#include <queue>
#include <vector>

#include "executor.hpp"

namespace rayline {

class ExactExecutor final : public Executor {
 public:
  explicit ExactExecutor(const Schedule& schedule) : schedule_(schedule) {}
  void dispatch(ActivityId id, const Activity& a) override;
  bool advance(std::vector<ExecutorEvent>& out) override;
  Time now() const override { return now_; }
  // Actual duration from the predicted one (default: identical).
  std::function<Time(ActivityId, const Activity&)> perturb;

 private:
  void try_start(ActivityId id);
  const Schedule& schedule_;
  Time now_ = 0;
  struct State { bool dispatched = false, started = false, done = false; Time end = 0; };
  std::vector<State> st_;
  std::vector<std::vector<ActivityId>> waiters_;  // dependency -> activities to re-check
  using Ev = std::pair<Time, ActivityId>;
  std::priority_queue<Ev, std::vector<Ev>, std::greater<>> running_;
  std::vector<ExecutorEvent> pending_starts_;
};

}  // namespace rayline

#include "sched/runtime/exact_executor.hpp"

#include <algorithm>

namespace rayline {

void ExactExecutor::dispatch(ActivityId id, const Activity&) {
  if (static_cast<std::size_t>(id) >= st_.size()) {
    st_.resize(static_cast<std::size_t>(id) + 1);
    waiters_.resize(static_cast<std::size_t>(id) + 1);
  }
  st_[id].dispatched = true;
  try_start(id);
}

// An activity starts when every dependency and its predecessor on every timeline it uses
// have finished (the executor follows each timeline in order, Sec. 4.1).
void ExactExecutor::try_start(ActivityId id) {
  State& s = st_[id];
  if (!s.dispatched || s.started) return;
  const Activity& a = schedule_.activity(id);
  Time start = now_;
  auto ready = [&](ActivityId p) {
    if (static_cast<std::size_t>(p) < st_.size() && st_[p].done) {
      start = std::max(start, st_[p].end);
      return true;
    }
    if (static_cast<std::size_t>(p) >= waiters_.size()) waiters_.resize(static_cast<std::size_t>(p) + 1);
    waiters_[p].push_back(id);
    return false;
  };
  for (ActivityId p : a.deps)
    if (!ready(p)) return;
  for (ActivityId p : a.timeline_prev)
    if (!ready(p)) return;
  s.started = true;
  s.start = start;
  const Time dur = a.cancelled ? 0 : perturb ? perturb(id, a) : a.duration;  // withdrawn: 0 s
  s.end = start + dur;
  running_.emplace(s.end, id);
  pending_starts_.push_back({ExecutorEvent::Type::Started, id, start});
}

bool ExactExecutor::advance(std::vector<ExecutorEvent>& out) {
  for (ActivityId id : reported_starts_) {
    State& s = st_[id];
    if (!s.done && s.end > s.start && schedule_.activity(id).cancelled) {
      s.end = s.start;  // the entry at the old end is skipped below
      running_.emplace(s.end, id);
    }
  }
  reported_starts_.clear();
  auto hand_out = [&] {
    for (const ExecutorEvent& e : pending_starts_) reported_starts_.push_back(e.activity);
    out.insert(out.end(), pending_starts_.begin(), pending_starts_.end());
    pending_starts_.clear();
  };
  if (!pending_starts_.empty()) {
    hand_out();
    return true;
  }
  while (!running_.empty() && (st_[running_.top().second].done || st_[running_.top().second].end != running_.top().first))
    running_.pop();  // superseded entries of withdrawn activities
  if (running_.empty()) return false;
  const Time t = running_.top().first;
  now_ = std::max(now_, t);
  while (!running_.empty() && running_.top().first == t) {
    const ActivityId id = running_.top().second;
    running_.pop();
    if (st_[id].done || st_[id].end != t) continue;
    st_[id].done = true;
    // A 0 s activity started in this very step: its start goes out before its end.
    if (auto it = std::find_if(pending_starts_.begin(), pending_starts_.end(),
                               [id](const ExecutorEvent& e) { return e.activity == id; });
        it != pending_starts_.end()) {
      out.push_back(*it);
      reported_starts_.push_back(id);
      pending_starts_.erase(it);
    }
    out.push_back({ExecutorEvent::Type::Finished, id, t});
    if (static_cast<std::size_t>(id) < waiters_.size()) {
      std::vector<ActivityId> w;
      w.swap(waiters_[id]);
      for (ActivityId x : w) try_start(x);
    }
  }
  hand_out();
  return true;
}

void ExactExecutor::run(const Sink& sink, Time until) {
  run_in_steps([this](std::vector<ExecutorEvent>& out) { return advance(out); }, sink, until);
}

}  // namespace rayline

#include "sched/runtime/exact_executor.hpp"

#include <algorithm>

namespace rayline {

void ExactExecutor::dispatch(ActivityId id, const Activity& a) {
  if (static_cast<std::size_t>(id) >= st_.size()) {
    st_.resize(static_cast<std::size_t>(id) + 1);
    waiters_.resize(static_cast<std::size_t>(id) + 1);
  }
  st_[id].dispatched = true;
  if (a.state == ActivityState::Failed) st_[id].placeholder = true;  // aborted before its dispatch
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
  if (!s.placeholder)
    for (ActivityId p : a.deps)
      if (!ready(p)) return;
  for (ActivityId p : a.timeline_prev)
    if (!ready(p)) return;
  s.started = true;
  if (s.placeholder) {
    s.end = s.start = start;
    finish(id);
    return;
  }
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
  if (!wakes_.empty() && !running_.empty() && wakes_.top() < running_.top().first) {
    now_ = std::max(now_, wakes_.top());  // a wake before the next end: an empty batch
    wakes_.pop();
    hand_out();
    return true;
  }
  if (running_.empty()) return false;
  const Time t = running_.top().first;
  now_ = std::max(now_, t);
  while (!wakes_.empty() && wakes_.top() <= t) wakes_.pop();  // delivered with this batch
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
    finish(id);
  }
  hand_out();
  return true;
}

void ExactExecutor::finish(ActivityId id) {
  st_[id].done = true;
  if (static_cast<std::size_t>(id) < waiters_.size()) {
    std::vector<ActivityId> w;
    w.swap(waiters_[id]);
    for (ActivityId x : w) try_start(x);
  }
}

void ExactExecutor::halt(const std::vector<DeviceId>& computes, const std::vector<ChannelId>& channels,
                         std::vector<ExecutorEvent>& events) {
  // The starts not handed out yet go first, so every Failed follows its Started.
  for (const ExecutorEvent& e : pending_starts_) reported_starts_.push_back(e.activity);
  events.insert(events.end(), pending_starts_.begin(), pending_starts_.end());
  pending_starts_.clear();
  std::vector<ActivityId> stopped;
  for (std::size_t id = 0; id < st_.size(); ++id) {
    const State& s = st_[id];
    if (!s.started || s.done) continue;
    const Activity& a = schedule_.activity(static_cast<ActivityId>(id));
    const bool lost = a.kind == ActivityKind::Exec
                          ? std::find(computes.begin(), computes.end(), a.device) != computes.end()
                          : std::find(channels.begin(), channels.end(), a.channel) != channels.end();
    if (lost) stopped.push_back(static_cast<ActivityId>(id));
  }
  for (ActivityId id : stopped) {
    st_[id].end = now_;
    st_[id].done = true;  // (its heap entry is skipped)
    events.push_back({ExecutorEvent::Type::Failed, id, now_});
  }
  halted_.insert(halted_.end(), stopped.begin(), stopped.end());  // woken by abort()
}

void ExactExecutor::abort(const std::vector<ActivityId>& ids) {
  for (ActivityId id : ids) {
    if (static_cast<std::size_t>(id) >= st_.size()) continue;
    State& s = st_[id];
    if (s.done) continue;
    if (s.started) {  // (running ones on lost devices were halted already)
      s.end = now_;
      s.done = true;
    } else {
      s.placeholder = true;
    }
  }
  // Only now, with everything aborted marked, may what waited for them go on.
  for (ActivityId id : halted_) finish(id);
  halted_.clear();
  for (ActivityId id : ids) {
    if (static_cast<std::size_t>(id) >= st_.size()) continue;
    if (st_[id].done) finish(id);
    else if (st_[id].dispatched) try_start(id);
  }
}

void ExactExecutor::run(const Sink& sink, Time until) {
  run_in_steps([this](std::vector<ExecutorEvent>& out) { return advance(out); }, sink, until);
}

}  // namespace rayline

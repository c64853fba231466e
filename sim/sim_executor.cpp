#include "sim/sim_executor.hpp"

#include <algorithm>
#include <chrono>

namespace rayline::sim {

namespace {
constexpr std::string_view kTransferOrderNames[] = {"channel", "resource", "exclusive"};
}  // namespace

std::string_view to_string(TransferOrder order) { return kTransferOrderNames[static_cast<std::size_t>(order)]; }

std::optional<TransferOrder> parse_transfer_order(std::string_view name) {
  for (std::size_t i = 0; i < std::size(kTransferOrderNames); ++i)
    if (kTransferOrderNames[i] == name) return static_cast<TransferOrder>(i);
  return std::nullopt;
}

SimExecutor::SimExecutor(SgPlatform& platform, const Schedule& schedule, SimExecutorOptions opt)
    : platform_(platform), schedule_(schedule), opt_(std::move(opt)),
      last_on_channel_(schedule.graph().channels.size(), kNone),
      running_(schedule.graph().computes.size(), 0),
      resource_user_(schedule.graph().resources.size(), kNone),
      resource_waiters_(schedule.graph().resources.size()) {
  const DeviceGraph& g = schedule.graph();
  contended_.resize(g.nodes.size());
  threads_.assign(g.nodes.size(), 0);
  busy_.assign(g.nodes.size(), 0);
  exec_slowdown_.assign(g.nodes.size(), 0.0);
  for (const ComputeDevice& c : g.computes)
    if (c.kind == ComputeKind::Cpu) ++threads_[static_cast<std::size_t>(c.node)];
  for (std::size_t i = 0; i < g.channels.size(); ++i)
    if (g.channels[i].cpu_contention > 0)
      contended_[static_cast<std::size_t>(g.memories[static_cast<std::size_t>(g.channels[i].to)].node)].push_back(
          static_cast<ChannelId>(i));
}

void SimExecutor::dispatch(ActivityId id, const Activity& a) {
  if (static_cast<std::size_t>(id) >= st_.size()) {
    st_.resize(static_cast<std::size_t>(id) + 1);
    waiters_.resize(static_cast<std::size_t>(id) + 1);
  }
  if (first_hold_) {  // the first plan's dispatch: the loop's start-up (stays until a completion resets it)
    release_ = std::max(release_, first_hold_());
    first_hold_ = nullptr;
  }
  State& s = st_[id];
  s.dispatched = true;
  s.dispatched_at = platform_.now();
  s.placeholder = s.placeholder || a.state == ActivityState::Failed;  // aborted before its dispatch
  s.release = release_;
  if (a.kind == ActivityKind::Transfer) {
    s.channel_prev = last_on_channel_[a.channel];
    last_on_channel_[a.channel] = id;
  }
  try_start(id);
}

bool SimExecutor::ready(ActivityId dep, ActivityId waiter) {
  if (static_cast<std::size_t>(dep) < st_.size() && st_[dep].done) return true;
  if (static_cast<std::size_t>(dep) >= waiters_.size()) waiters_.resize(static_cast<std::size_t>(dep) + 1);
  waiters_[dep].push_back(waiter);
  return false;
}

Time SimExecutor::latest_end(const ActivityList& ids) const {
  Time t = -kNever;
  for (ActivityId p : ids) t = std::max(t, schedule_.activity(p).end);
  return t;
}

void SimExecutor::try_start(ActivityId id) {
  State& s = st_[id];
  if (!s.dispatched || s.started) return;
  const Activity& a = schedule_.activity(id);
  if (!s.placeholder)
    for (ActivityId p : a.deps)
      if (!ready(p, id)) return;
  if (a.kind == ActivityKind::Exec || opt_.transfer_order == TransferOrder::Resource) {
    for (ActivityId p : a.timeline_prev)
      if (!ready(p, id)) return;
  } else if (s.channel_prev != kNone && !ready(s.channel_prev, id)) {
    return;
  }
  if (s.placeholder) {  // Schedule::fail aborted it: it moves nothing and reports nothing
    s.started = s.done = true;
    wake_waiters(id);
    return;
  }
  // A T-job that, once dispatched, waited for an activity of another thread (not its own
  // channel's previous transfer, after which the loader goes straight on): that thread is
  // woken when it may start (ControlLoop::wake).
  if (const Time wake = schedule_.graph().loop.wake; wake > 0 && !s.woken && a.kind == ActivityKind::Transfer) {
    s.woken = true;
    const Time dep_end = latest_end(a.deps), prev_end = latest_end(a.timeline_prev);
    if (dep_end > s.dispatched_at && dep_end >= prev_end) s.release = std::max(s.release, dep_end + wake);
  }
  // An E-job dispatched before its device's previous activity ended, its inputs there by
  // then: the thread's hand-over (ControlLoop::pickup).
  if (const Time pickup = schedule_.graph().loop.pickup; pickup > 0 && !s.picked && a.kind == ActivityKind::Exec) {
    s.picked = true;
    const Time dep_end = latest_end(a.deps), prev_end = latest_end(a.timeline_prev);
    if (prev_end > s.dispatched_at && dep_end <= prev_end) s.release = std::max(s.release, prev_end + pickup);
  }
  if (s.release > platform_.now()) {  // the control loop has not dispatched it yet
    if (!s.timer) {
      s.timer = true;
      platform_.start_timer(s.release - platform_.now(), [this, id](const SgCompletion&) {
        st_[id].timer = false;
        st_[id].release = 0;
        try_start(id);
      });
    }
    return;
  }
  if (a.kind == ActivityKind::Transfer && !a.cancelled && opt_.transfer_order == TransferOrder::Exclusive &&
      !resources_free(id, a))
    return;
  s.started = true;
  s.started_at = platform_.now();
  buffered_.push_back({ExecutorEvent::Type::Started, id, platform_.now()});
  if (a.cancelled) {  // withdrawn (Schedule::cancel): done the moment it may run, nothing moves
    on_done(id, platform_.now(), true);
    return;
  }
  auto cb = [this, id](const SgCompletion& c) { on_done(id, c.finish_s, c.ok); };
  if (a.kind == ActivityKind::Transfer) {
    if (const Channel& ch = schedule_.graph().channels[static_cast<std::size_t>(a.channel)]; ch.exec_contention > 0) {
      s.slows_cpu = true;
      load_changed(ch, +1);
    }
    s.sg = platform_.start_transfer(a.channel, a.bytes, cb);
  } else {
    const double f = opt_.exec_factor ? opt_.exec_factor(id, a) : 1.0;
    cpu_changed(a.device, true);
    s.sg = platform_.start_exec(a.device, a.duration * f, cb);
  }
}

void SimExecutor::load_changed(const Channel& c, int delta) {
  const DeviceGraph& g = schedule_.graph();
  const auto n = static_cast<std::size_t>(g.memories[static_cast<std::size_t>(c.to)].node);
  exec_slowdown_[n] = std::max(0.0, exec_slowdown_[n] + delta * c.exec_contention);
  if (delta < 0 && exec_slowdown_[n] < 1e-12) exec_slowdown_[n] = 0;
  for (DeviceId d : g.nodes[n].computes)
    if (g.computes[static_cast<std::size_t>(d)].kind == ComputeKind::Cpu) platform_.set_device_slowdown(d, 1 + exec_slowdown_[n]);
}

void SimExecutor::cpu_changed(DeviceId d, bool running) {
  const auto di = static_cast<std::size_t>(d);
  if (running_[di] == static_cast<char>(running)) return;
  running_[di] = running;
  const DeviceGraph& g = schedule_.graph();
  if (g.computes[di].kind != ComputeKind::Cpu) return;
  const auto n = static_cast<std::size_t>(g.computes[di].node);
  busy_[n] += running ? 1 : -1;
  const double share = static_cast<double>(busy_[n]) / threads_[n];
  for (ChannelId c : contended_[n]) {
    const Channel& ch = g.channels[static_cast<std::size_t>(c)];
    platform_.set_channel_bandwidth(c, ch.bandwidth / (1 + ch.cpu_contention * share));
  }
}

bool SimExecutor::resources_free(ActivityId id, const Activity& a) {
  const auto& res = schedule_.graph().channels[a.channel].resources;
  bool free = true;
  for (ResourceId r : res)
    if (resource_user_[r] != kNone) {
      resource_waiters_[r].push_back(id);
      free = false;
    }
  if (free) {
    for (ResourceId r : res) resource_user_[r] = id;
    st_[id].holds_resources = true;
  }
  return free;
}

void SimExecutor::release_resources(const Activity& a) {
  woken_.clear();
  for (ResourceId r : schedule_.graph().channels[a.channel].resources) {
    resource_user_[r] = kNone;
    woken_.insert(woken_.end(), resource_waiters_[r].begin(), resource_waiters_[r].end());
    resource_waiters_[r].clear();
  }
  // Plan order (activity ids are commit order) among the waiters; one waiting on several
  // freed resources is listed once.
  std::sort(woken_.begin(), woken_.end());
  woken_.erase(std::unique(woken_.begin(), woken_.end()), woken_.end());
}

void SimExecutor::on_done(ActivityId id, Time finish, bool ok) {
  const auto t0 = std::chrono::steady_clock::now();
  st_[id].done = true;
  if (const Activity& a = schedule_.activity(id); a.kind == ActivityKind::Exec) {
    cpu_changed(a.device, false);
  } else if (st_[id].slows_cpu) {
    st_[id].slows_cpu = false;
    load_changed(schedule_.graph().channels[static_cast<std::size_t>(a.channel)], -1);
  }
  std::vector<ActivityId> freed;
  if (st_[id].holds_resources) {
    st_[id].holds_resources = false;
    release_resources(schedule_.activity(id));
    freed.swap(woken_);
  }
  std::vector<ExecutorEvent> events;
  events.swap(buffered_);
  events.push_back({ok ? ExecutorEvent::Type::Finished : ExecutorEvent::Type::Failed, id, finish});
  std::vector<ActivityId> w;
  if (static_cast<std::size_t>(id) < waiters_.size()) w.swap(waiters_[id]);
  // Report first (the loop may re-plan and dispatch at this very instant), then start
  // whatever this completion unblocked. What the loop dispatches in answer to a finished
  // E-job waits for the loop's latency (DeviceGraph::loop).
  const ControlLoop& loop = schedule_.graph().loop;
  const Activity& done = schedule_.activity(id);
  if (ok && loop.modelled() && done.kind == ActivityKind::Exec)
    release_ = finish + loop.latency(finish - st_[id].started_at);
  if (sink_) (*sink_)(events);
  release_ = 0;
  if (!freed.empty()) {  // Exclusive: what this completion unblocked, in plan order
    w.insert(w.end(), freed.begin(), freed.end());
    std::sort(w.begin(), w.end());
    w.erase(std::unique(w.begin(), w.end()), w.end());
  }
  for (ActivityId x : w) try_start(x);  // (one that finds a resource busy again waits on it)
  callback_wall_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void SimExecutor::wake_at(Time t) {
  platform_.start_timer(std::max(0.0, t - platform_.now()), [this](const SgCompletion&) {
    std::vector<ExecutorEvent> events;
    events.swap(buffered_);
    if (sink_) (*sink_)(events);
  });
}

void SimExecutor::halt(const std::vector<DeviceId>& computes, const std::vector<ChannelId>& channels,
                       std::vector<ExecutorEvent>& events) {
  events.insert(events.end(), buffered_.begin(), buffered_.end());  // starts not reported yet
  buffered_.clear();
  for (std::size_t id = 0; id < st_.size(); ++id) {
    State& s = st_[id];
    if (!s.started || s.done) continue;
    const Activity& a = schedule_.activity(static_cast<ActivityId>(id));
    const bool lost = a.kind == ActivityKind::Exec
                          ? std::find(computes.begin(), computes.end(), a.device) != computes.end()
                          : std::find(channels.begin(), channels.end(), a.channel) != channels.end();
    if (!lost) continue;
    if (s.sg != 0) platform_.cancel(s.sg);
    s.done = true;
    if (a.kind == ActivityKind::Exec) cpu_changed(a.device, false);
    if (s.slows_cpu) {
      s.slows_cpu = false;
      load_changed(schedule_.graph().channels[static_cast<std::size_t>(a.channel)], -1);
    }
    if (s.holds_resources) {
      s.holds_resources = false;
      release_resources(a);
      halted_.insert(halted_.end(), woken_.begin(), woken_.end());
    }
    events.push_back({ExecutorEvent::Type::Failed, static_cast<ActivityId>(id), platform_.now()});
    halted_.push_back(static_cast<ActivityId>(id));
  }
}

void SimExecutor::wake_waiters(ActivityId id) {
  if (static_cast<std::size_t>(id) >= waiters_.size()) return;
  std::vector<ActivityId> w;
  w.swap(waiters_[id]);
  for (ActivityId x : w) try_start(x);
}

void SimExecutor::abort(const std::vector<ActivityId>& ids) {
  for (ActivityId id : ids) {
    if (static_cast<std::size_t>(id) >= st_.size()) continue;
    State& s = st_[id];
    if (s.done) continue;
    if (s.started) {  // (running ones on lost devices were halted already)
      if (s.sg != 0) platform_.cancel(s.sg);
      s.done = true;
    } else {
      s.placeholder = true;
    }
  }
  // Only now, with everything aborted marked done, may what waited for them start (a
  // halted T-job's resources may also have freed waiting ones, listed with them).
  std::vector<ActivityId> wake;
  wake.swap(halted_);
  wake.insert(wake.end(), ids.begin(), ids.end());
  for (ActivityId id : wake) {
    if (static_cast<std::size_t>(id) >= st_.size()) continue;
    if (st_[id].done) wake_waiters(id);
    else try_start(id);  // a placeholder, or a T-job that waited for a resource the halt freed
  }
}

void SimExecutor::run(const Sink& sink, Time until) {
  const Sink before_until = [this, &sink, until](std::vector<ExecutorEvent>& events) {
    if (now() < until) sink(events);
  };
  sink_ = &before_until;
  if (until == kNever) platform_.run();
  else platform_.run_until(until);
  sink_ = nullptr;
  if (!buffered_.empty()) {
    std::vector<ExecutorEvent> events;
    events.swap(buffered_);
    before_until(events);
  }
}

}  // namespace rayline::sim

#include "render/engine/local_executor.hpp"

#include <xmmintrin.h>
#include <pmmintrin.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <system_error>

namespace rayline::engine {

LocalExecutor::LocalExecutor(const DeviceGraph& g, TaskFactory factory, TaskFactory hint_factory)
    : g_(g), factory_(std::move(factory)), hint_factory_(std::move(hint_factory)), t0_(std::chrono::steady_clock::now()),
      lanes_(g.computes.size() + g.resources.size()), busy_(lanes_.size(), 0.0), running_(lanes_.size(), 0),
      lost_(lanes_.size(), 0) {
  try {
    for (std::size_t i = 0; i < lanes_.size(); ++i) threads_.emplace_back([this, i] { worker(i); });
  } catch (const std::system_error& e) {
    // Out of threads (an address-space or process limit): the ones started stop and are
    // joined, so the failure reaches the caller instead of std::terminate (a joinable
    // std::thread destroyed).
    stop_threads();
    throw std::runtime_error("cannot start " + std::to_string(lanes_.size()) +
                             " worker threads (one per compute device and channel): " + e.code().message());
  }
}

void LocalExecutor::stop_threads() {
  {
    std::lock_guard lk(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_) t.join();
  threads_.clear();
}

LocalExecutor::~LocalExecutor() { stop_threads(); }

Time LocalExecutor::now() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
}

void LocalExecutor::dispatch(ActivityId id, const Activity& a) {
  const bool aborted = a.state == ActivityState::Failed;  // before its dispatch (a fault at the start)
  Item it{id, {a.deps.begin(), a.deps.end()}, aborted ? Task{} : factory_(id, a),
          hint_factory_ && !aborted ? hint_factory_(id, a) : Task{}, {a.timeline_prev.begin(), a.timeline_prev.end()}};
  it.wait.insert(it.wait.end(), a.timeline_prev.begin(), a.timeline_prev.end());
  const std::size_t lane = a.kind == ActivityKind::Exec
                               ? static_cast<std::size_t>(a.device)
                               : g_.computes.size() + static_cast<std::size_t>(g_.channels[a.channel].resources.front());
  Task hint;
  {
    std::lock_guard lk(mu_);
    if (static_cast<std::size_t>(id) >= done_.size()) done_.resize(static_cast<std::size_t>(id) + 1, 0);
    if (static_cast<std::size_t>(id) >= lane_of_.size()) lane_of_.resize(static_cast<std::size_t>(id) + 1, -1);
    lane_of_[static_cast<std::size_t>(id)] = static_cast<std::int32_t>(lane);
    if (aborted) {
      if (lost_[lane]) {  // nothing runs on a lost lane any more
        done_[static_cast<std::size_t>(id)] = 1;
        return;
      }
      it.placeholder = true;
      it.wait = it.prev;
    }
    lanes_[lane].push_back(std::move(it));
    ++in_flight_;
    // Next behind a running task: its lane's thread is busy, so the hint runs here.
    if (lanes_[lane].size() == 1 && running_[lane] && !failure_) hint = std::move(lanes_[lane].front().hint);
    if (hint) lanes_[lane].front().hint = nullptr;
  }
  cv_.notify_all();
  if (hint) {
    try {
      hint();
    } catch (...) {  // only starts work: a failure shows again in the task itself
    }
  }
}

bool LocalExecutor::ready(const Item& it) const {
  for (ActivityId p : it.wait)
    if (static_cast<std::size_t>(p) >= done_.size() || !done_[static_cast<std::size_t>(p)]) return false;
  return true;
}

void LocalExecutor::fire_hint(std::size_t lane, std::unique_lock<std::mutex>& lk) {
  if (lanes_[lane].empty() || !lanes_[lane].front().hint) return;
  Task hint = std::move(lanes_[lane].front().hint);
  lanes_[lane].front().hint = nullptr;  // cleared in every case: the worker waits on it
  if (failure_) return;                 // after a failure nothing more is started
  lk.unlock();
  try {
    hint();  // only starts work (read-ahead): a failure there shows again in the task itself
  } catch (...) {
  }
  lk.lock();
}

void LocalExecutor::worker(std::size_t lane) {
  // Embree wants flush-to-zero and denormals-are-zero in every tracing thread.
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  std::unique_lock lk(mu_);
  for (;;) {
    // The next item's hint runs as soon as it is next, before it may start.
    cv_.wait(lk, [&] {
      return stop_ || (!lost_[lane] && !lanes_[lane].empty() && (lanes_[lane].front().hint || ready(lanes_[lane].front())));
    });
    if (stop_) return;
    if (lanes_[lane].front().hint) {
      fire_hint(lane, lk);
      continue;
    }
    Item it = std::move(lanes_[lane].front());
    lanes_[lane].pop_front();
    if (it.placeholder) {
      done_[static_cast<std::size_t>(it.id)] = 1;
      --in_flight_;
      cv_.notify_all();
      continue;
    }
    const bool skip = failure_ != nullptr;  // after a failure: finish quickly, run nothing
    const Time t_start = now();
    events_.push_back({ExecutorEvent::Type::Started, it.id, t_start});
    running_[lane] = 1;
    fire_hint(lane, lk);  // the next item's read-ahead overlaps this one
    lk.unlock();
    cv_.notify_all();
    std::exception_ptr err;
    std::string recoverable;  // an ActivityError: reported Failed, the run re-plans it
    std::exception_ptr cause;
    if (!skip && it.task) {
      try {
        it.task();
      } catch (const ActivityError& e) {
        recoverable = e.what();
        if (recoverable.empty()) recoverable = "failed";
        cause = e.cause();
      } catch (...) {
        err = std::current_exception();
      }
    }
    it.task = nullptr;  // release what it captured before reporting
    const Time t_end = now();
    lk.lock();
    busy_[lane] += t_end - t_start;
    running_[lane] = 0;
    if (err && !failure_) failure_ = err;
    // A recoverable failure is not done: what waits for it waits for the loop's abort().
    const bool failed = err || skip || !recoverable.empty();
    if (recoverable.empty()) done_[static_cast<std::size_t>(it.id)] = 1;
    else why_.push_back({it.id, std::move(recoverable), std::move(cause)});
    --in_flight_;
    events_.push_back({failed ? ExecutorEvent::Type::Failed : ExecutorEvent::Type::Finished, it.id, t_end});
    cv_.notify_all();
  }
}

bool LocalExecutor::advance(std::vector<ExecutorEvent>& out) {
  std::unique_lock lk(mu_);
  for (;;) {
    auto woke = [&] { return !events_.empty() || in_flight_ == 0; };
    if (wakes_.empty()) {
      cv_.wait(lk, woke);
      break;
    }
    const auto deadline = t0_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                    std::chrono::duration<double>(wakes_.front()));
    if (cv_.wait_until(lk, deadline, woke)) break;
    // The wake's time came with nothing to report: an empty batch then.
    std::pop_heap(wakes_.begin(), wakes_.end(), std::greater<>{});
    wakes_.pop_back();
    return true;
  }
  if (events_.empty()) return false;
  out.insert(out.end(), events_.begin(), events_.end());
  events_.clear();
  return true;
}

void LocalExecutor::run(const Sink& sink, Time until) {
  run_in_steps([this](std::vector<ExecutorEvent>& out) { return advance(out); }, sink, until);
}

void LocalExecutor::wake_at(Time t) {
  {
    std::lock_guard lk(mu_);
    wakes_.push_back(t);
    std::push_heap(wakes_.begin(), wakes_.end(), std::greater<>{});
  }
  cv_.notify_all();  // (a wake from another thread: the loop's wait sees the new deadline)
}

void LocalExecutor::halt(const std::vector<DeviceId>& computes, const std::vector<ChannelId>&,
                         std::vector<ExecutorEvent>& events) {
  // Lost channels need nothing here: their T-jobs are all aborted (Schedule::fail) before
  // they could start, and a resource's thread serves the channels still alive.
  std::unique_lock lk(mu_);
  for (DeviceId d : computes) lost_[static_cast<std::size_t>(d)] = 1;
  cv_.wait(lk, [&] {
    for (DeviceId d : computes)
      if (running_[static_cast<std::size_t>(d)]) return false;
    return true;
  });
  // Placeholders (activities aborted before the loss) would wait for a thread that no longer
  // runs anything: they end now, so what waits for them is not held up.
  for (DeviceId d : computes) {
    auto& lane = lanes_[static_cast<std::size_t>(d)];
    for (auto it = lane.begin(); it != lane.end();)
      if (it->placeholder) {
        done_[static_cast<std::size_t>(it->id)] = 1;
        --in_flight_;
        it = lane.erase(it);
      } else {
        ++it;
      }
  }
  cv_.notify_all();
  events.insert(events.end(), events_.begin(), events_.end());
  events_.clear();
}

void LocalExecutor::abort(const std::vector<ActivityId>& ids) {
  {
    std::lock_guard lk(mu_);
    for (ActivityId id : ids) {
      const auto i = static_cast<std::size_t>(id);
      if (i >= done_.size() || done_[i]) continue;
      const auto l = static_cast<std::size_t>(lane_of_[i]);
      auto& lane = lanes_[l];
      const auto it = std::find_if(lane.begin(), lane.end(), [id](const Item& x) { return x.id == id; });
      if (it == lane.end()) {  // one that failed by itself has left its lane already
        done_[i] = 1;
      } else if (lost_[l]) {  // nothing runs on a lost lane any more
        done_[i] = 1;
        lane.erase(it);
        --in_flight_;
      } else {  // it keeps its place: done once its predecessors are
        it->placeholder = true;
        it->task = nullptr;
        it->hint = nullptr;
        it->wait = it->prev;
      }
    }
  }
  cv_.notify_all();
}

std::string LocalExecutor::why_failed(ActivityId id) const {
  std::lock_guard lk(mu_);
  for (auto it = why_.rbegin(); it != why_.rend(); ++it)
    if (it->id == id) return it->what;
  return {};
}

std::exception_ptr LocalExecutor::cause_of(ActivityId id) const {
  std::lock_guard lk(mu_);
  for (auto it = why_.rbegin(); it != why_.rend(); ++it)
    if (it->id == id) return it->cause;
  return nullptr;
}

std::exception_ptr LocalExecutor::failure() const {
  std::lock_guard lk(mu_);
  return failure_;
}

std::vector<double> LocalExecutor::busy_seconds() const {
  std::lock_guard lk(mu_);
  return busy_;
}

}  // namespace rayline::engine

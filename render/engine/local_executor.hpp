// The Executor seam (docs/architecture.md) on this machine: one worker thread per compute device (a
// CPU hardware thread, as in the paper) and one per channel resource (the disk→RAM
// channel: reads and BVH builds). Each thread runs its timeline in commit order; an
// activity starts once its dependencies and its timeline predecessors have finished.
// Times are wall-clock seconds since the executor was created.
//
// Read-ahead hints: an optional second factory gives an activity a *hint*, run once when
// the activity becomes the next in its lane: by the lane's thread when it starts the
// predecessor or waits for the activity's dependencies, or by the dispatching thread when
// the activity is queued behind a running one. A hint may only start work that touches no
// memory the plan accounts for: the renderer uses it to read the next block file into a
// staging buffer while the channel is still building the previous block's BVH
// (BlockStore::read_ahead), so the disk and the CPU side of consecutive T-jobs overlap.
#pragma once
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "sched/runtime/executor.hpp"

namespace rayline::engine {

class LocalExecutor : public Executor {
 public:
  using Task = std::function<void()>;
  // Called on the loop's thread at dispatch: returns the work of the activity (it may
  // capture what it needs; it runs on the timeline's thread).
  using TaskFactory = std::function<Task(ActivityId, const Activity&)>;

  // Starts the threads; std::runtime_error "cannot start N worker threads ...: reason" when
  // the system refuses one (none is left running then).
  LocalExecutor(const DeviceGraph& g, TaskFactory factory, TaskFactory hint_factory = {});
  ~LocalExecutor() override;
  LocalExecutor(const LocalExecutor&) = delete;
  LocalExecutor& operator=(const LocalExecutor&) = delete;

  void dispatch(ActivityId id, const Activity& a) override;
  Time now() const override;
  void run(const Sink& sink, Time until) override;
  void wake_at(Time t) override;
  // A lost compute device's thread finishes the task it is running (a thread is not
  // stopped part-way: its partial results would be lost) and starts nothing more.
  void halt(const std::vector<DeviceId>& computes, const std::vector<ChannelId>& channels,
            std::vector<ExecutorEvent>& events) override;
  void abort(const std::vector<ActivityId>& ids) override;
  std::string why_failed(ActivityId id) const override;
  std::exception_ptr cause_of(ActivityId id) const override;
  bool gave_up() const override { return failure() != nullptr; }
  // One step: waits for the next batch of events and appends it to `out`; false when
  // nothing is in flight (tests step the executor by hand).
  bool advance(std::vector<ExecutorEvent>& out);

  // The first exception a task threw (the run stops dispatching after it).
  std::exception_ptr failure() const;
  // Per thread: seconds spent running tasks (for the utilisation metrics).
  std::vector<double> busy_seconds() const;

 private:
  struct Item {
    ActivityId id;
    std::vector<ActivityId> wait;  // deps + timeline predecessors
    Task task;
    Task hint;  // run once when the item is next in its lane (read-ahead), then cleared
    std::vector<ActivityId> prev;  // its timeline predecessors
    // Aborted before it started (Schedule::fail): it ends, silently and at once, when its
    // timeline predecessors have (it keeps the lane's order).
    bool placeholder = false;
  };
  void worker(std::size_t lane);
  void stop_threads();  // tells the threads to stop and joins them
  bool ready(const Item& it) const;
  void fire_hint(std::size_t lane, std::unique_lock<std::mutex>& lk);

  const DeviceGraph& g_;
  TaskFactory factory_, hint_factory_;
  std::chrono::steady_clock::time_point t0_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::deque<Item>> lanes_;  // computes first, then resources
  std::vector<char> done_;
  std::vector<ExecutorEvent> events_;
  std::vector<double> busy_;
  std::vector<char> running_;  // per lane: a task is running
  std::vector<char> lost_;     // per lane: its device was lost (halt)
  std::vector<std::int32_t> lane_of_;  // per activity: its lane
  std::vector<Time> wakes_;            // a min-heap (wake_at)
  struct Why {
    ActivityId id;
    std::string what;
    std::exception_ptr cause;
  };
  std::vector<Why> why_;  // ActivityErrors
  std::size_t in_flight_ = 0;
  bool stop_ = false;
  std::exception_ptr failure_;
  std::vector<std::thread> threads_;
};

}  // namespace rayline::engine

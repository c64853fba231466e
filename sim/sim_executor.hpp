// SimExecutor: the Executor seam on SimGrid. Activities are started from
// maestro as their dependencies allow, each compute device runs its E-jobs in plan order,
// each channel its T-jobs in plan order (the paper's per-channel timelines, Sec. 4.1).
// The planner serialises T-jobs per *resource*; by default SimGrid does not: two channels
// that share a medium (both directions of a half-duplex SATA link, two LAN channels out of
// one NIC) may run at once and share its bandwidth. That is where reality departs from the
// plan; the runtime loop then re-plans from the measured times (Schedule::reproject).
// TransferOrder selects the runtime's policy for shared media (Rayline's choice; the paper
// keeps one timeline per channel, Sec. 4.1, and says nothing of shared media).
#pragma once
#include <functional>
#include <optional>
#include <string_view>
#include <vector>

#include "sched/runtime/executor.hpp"
#include "sim/sg_platform.hpp"

namespace rayline::sim {

enum class TransferOrder {
  Channel,    // each channel in plan order; channels sharing a medium run at once and share it
  Resource,   // every resource timeline in plan order too: no contention, reality = plan
  Exclusive,  // one T-job per resource at a time, but a ready T-job may overtake one whose
              // data is not there yet (work-conserving; waiting T-jobs start in plan order)
};

std::string_view to_string(TransferOrder order);                     // channel | resource | exclusive
std::optional<TransferOrder> parse_transfer_order(std::string_view name);  // nullopt: none of them

struct SimExecutorOptions {
  TransferOrder transfer_order = TransferOrder::Channel;
  // Actual E-job duration = predicted x exec_factor(activity); default exact.
  std::function<double(ActivityId, const Activity&)> exec_factor;
};

class SimExecutor final : public Executor {
 public:
  SimExecutor(SgPlatform& platform, const Schedule& schedule, SimExecutorOptions opt = {});
  void dispatch(ActivityId id, const Activity& a) override;
  Time now() const override { return platform_.now(); }
  // SimGrid runs to completion (or to `until`) and reports from inside its event
  // processing; batches at or past `until` are not delivered.
  void run(const Sink& sink, Time until) override;
  void wake_at(Time t) override;
  // Activities running on lost devices stop now and are reported Failed (a host turned off).
  void halt(const std::vector<DeviceId>& computes, const std::vector<ChannelId>& channels,
            std::vector<ExecutorEvent>& events) override;
  void abort(const std::vector<ActivityId>& ids) override;

  // What the first plan dispatches starts no earlier than `hold()`, asked at that
  // dispatch: the loop's work before its first plan (ControlLoop::per_camera_ray, the
  // workload's first wave). Set before the run.
  void hold_first_dispatch(std::function<Time()> hold) { first_hold_ = std::move(hold); }

  // Wall seconds spent in our completion handling (runtime loop, scheduler, bookkeeping);
  // the rest of run() is SimGrid's own work (max-min solver, event queue).
  double callback_wall_seconds() const { return callback_wall_; }

 private:
  void try_start(ActivityId id);
  Time latest_end(const ActivityList& ids) const;  // the latest end of `ids`; -kNever when empty
  void on_done(ActivityId id, Time finish, bool ok);
  bool ready(ActivityId dep, ActivityId waiter);
  // TransferOrder::Exclusive: are all of the channel's resources free? If not, wait on them.
  bool resources_free(ActivityId id, const Activity& a);
  void release_resources(const Activity& a);
  // Channel::cpu_contention: an E-job started or ended on CPU device d; the bandwidth of
  // its node's contended channels follows the threads that run E-jobs.
  void cpu_changed(DeviceId d, bool running);
  // A T-job on a channel with Channel::exec_contention started (+1) or ended (-1): the
  // node's CPU threads run their E-jobs slower while it runs.
  void load_changed(const Channel& c, int delta);

  SgPlatform& platform_;
  const Schedule& schedule_;
  SimExecutorOptions opt_;
  struct State {
    bool dispatched = false, started = false, done = false;
    bool holds_resources = false;  // TransferOrder::Exclusive: running on its channel's resources
    ActivityId channel_prev = kNone;
    SgActivityId sg = 0;  // the SimGrid activity while started (0: none, or a 0 s withdrawn one)
    bool placeholder = false;  // aborted before it started: ends at once after its timeline predecessors
    Time started_at = 0;
    // The control loop (DeviceGraph::loop): dispatched in answer to a finished E-job, it
    // starts no earlier than that job's end plus the loop's latency.
    Time release = 0;
    bool timer = false;  // a timer will try it again at `release`
    Time dispatched_at = 0;
    bool woken = false;  // ControlLoop::wake applied (once, when it first could start)
    bool picked = false;  // ControlLoop::pickup applied (once, when it first could start)
    bool slows_cpu = false;  // a running T-job counted in exec_slowdown_
  };
  Time release_ = 0;  // for activities dispatched during the current report (0: none)
  std::function<Time()> first_hold_;  // hold_first_dispatch, until the first dispatch
  void wake_waiters(ActivityId id);
  std::vector<ActivityId> halted_;  // stopped by halt(), their waiters woken by abort()
  std::vector<State> st_;
  std::vector<std::vector<ActivityId>> waiters_;
  std::vector<ActivityId> last_on_channel_;
  std::vector<char> running_;  // per compute device: an E-job runs on it
  // Per node: its CPU threads and the contended channels into its memories (empty: none).
  std::vector<std::vector<ChannelId>> contended_;
  std::vector<int> threads_, busy_;
  std::vector<double> exec_slowdown_;  // per node: the sum of its running T-jobs' exec_contention
  // TransferOrder::Exclusive, per resource: the T-job using it (kNone: free), and the
  // T-jobs waiting for it (tried in plan order when it frees).
  std::vector<ActivityId> resource_user_;
  std::vector<std::vector<ActivityId>> resource_waiters_;
  std::vector<ActivityId> woken_;
  std::vector<ExecutorEvent> buffered_;  // Started events, delivered with the next batch
  const Sink* sink_ = nullptr;
  double callback_wall_ = 0;
};

}  // namespace rayline::sim

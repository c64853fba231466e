// The Executor of a distributed render on rank 0 (render/mpi/README.md): LocalExecutor's
// lanes, one per compute device and channel resource of the whole DCG, where a lane of
// another rank's device or channel runs a proxy: it sends the activity to the rank that owns
// it (Load, Exec, Send), waits for that rank's Done, and so reports the activity started and
// finished at the times the master saw them, as the runtime loop needs. Rank 0's own lanes
// run their work here, as on one machine.
#pragma once
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "render/accel/aggregate.hpp"
#include "render/engine/cluster.hpp"
#include "render/engine/local_executor.hpp"
#include "render/mpi/comm.hpp"
#include "render/mpi/message.hpp"
#include "render/mpi/node.hpp"

namespace rayline::mpi {

// Replies awaited by proxies, by activity.
class Pending {
 public:
  // `ranks`: the ranks whose loss fails the activity (its owner, a transfer's two ends).
  void expect(ActivityId id, std::vector<int> ranks);
  // The reply's buffer (Done), or throws ActivityError with the rank's reason.
  Buffer wait(ActivityId id);
  void complete(ActivityId id, bool ok, const std::string& why, Buffer reply = {});
  // Every reply still awaited fails with `why` (a rank that gave up).
  void fail_all(const std::string& why);
  // Every activity involving `rank`, awaited now or later, fails with `why` (a lost rank).
  void fail_rank(int rank, const std::string& why);

 private:
  struct Slot {
    bool done = false, ok = true;
    std::string why;
    Buffer reply;
    std::vector<int> ranks;
  };
  std::map<int, std::string> lost_;  // rank -> why
  std::mutex mu_;
  std::condition_variable cv_;
  std::map<ActivityId, Slot> slots_;
  std::string failed_;
};

// Per rank: seconds its E-jobs traced on that rank, and their seconds as rank 0 saw them
// (messages, the outputs' way back and waits included).
class ExecTime {
 public:
  explicit ExecTime(int ranks) : traced_(std::size_t(ranks), 0.0), seen_(std::size_t(ranks), 0.0) {}
  void add(int rank, double traced, double seen) {
    std::lock_guard lk(mu_);
    traced_[std::size_t(rank)] += traced;
    seen_[std::size_t(rank)] += seen;
  }
  std::pair<double, double> of(int rank) const {
    std::lock_guard lk(mu_);
    return {traced_[std::size_t(rank)], seen_[std::size_t(rank)]};
  }

 private:
  mutable std::mutex mu_;
  std::vector<double> traced_, seen_;
};

class ClusterTasks {
 public:
  ClusterTasks(Comm& comm, Node& self, const engine::ClusterWork& w, Pending& pending, ExecTime& time);
  engine::LocalExecutor::Task task(ActivityId id, const Activity& a);
  engine::LocalExecutor::Task hint(ActivityId id, const Activity& a) const;

 private:
  struct Victims {  // per rank: scene blocks (cells) and ray queues leaving its RAM, its GPU
    std::vector<std::uint32_t> cells;
    std::vector<std::int32_t> queues;
    std::vector<std::uint32_t> gpu_cells;
    std::vector<std::int32_t> gpu_queues;
  };
  void evict_here(const Victims& v);  // rank 0's
  static Writer& with_victims(Writer& w, const Victims& v);
  std::map<int, Victims> victims_of(ActivityId id);
  void send(int rank, const Buffer& b);  // comm_.send, a lost rank an ActivityError
  int rank_of(MemId m) const { return int(w_.g.memories[std::size_t(m)].node); }
  // Evictions on other ranks than `main` (synchronous), then rank 0's own.
  void evict_elsewhere(ActivityId id, std::map<int, Victims>& v, int main);
  engine::LocalExecutor::Task exec(ActivityId id, const Activity& a, std::map<int, Victims> v);
  engine::LocalExecutor::Task transfer(ActivityId id, const Activity& a, std::map<int, Victims> v);

  Comm& comm_;
  Node& self_;
  engine::ClusterWork w_;
  Pending& pending_;
  ExecTime& time_;
  std::vector<std::unique_ptr<accel::Aggregate>> aggregates_;  // rank 0's CPU threads
  std::vector<int> local_index_;                               // per compute device: its thread on its rank
  std::size_t ev_cursor_ = 0;
  std::map<ActivityId, std::map<int, Victims>> victims_;
};

class MpiExecutor final : public engine::LocalExecutor {
 public:
  MpiExecutor(const DeviceGraph& g, std::unique_ptr<ClusterTasks> tasks, Pending& pending);
  // Releases the proxies still waiting (a run that ended on an error), then joins the lanes.
  ~MpiExecutor() override;

 private:
  Pending& pending_;
  std::unique_ptr<ClusterTasks> tasks_;
};

}  // namespace rayline::mpi

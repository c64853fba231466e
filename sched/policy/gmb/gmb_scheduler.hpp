// Greedy Makespan Balancing (Sec. 4.2-4.4).
//   * device selection: the compute device whose timeline ends first (least planned time);
//   * job selection (Sec. 4.3): the queued E-job that can start earliest on it, i.e. the
//     smallest fetching overhead; ties (e.g. all fetch-free) go to the smallest
//     T_SETUP / T_EXEC (highest granularity), then to the oldest job;
//   * fetch paths by SDC (Eq. 3), committed as chained T-jobs before the E-job;
//   * repeat until the queue is empty or every device is planned up to now + k;
//   * aging (Sec. 4.3, "Possible starvation and workarounds"): a job that has waited in
//     the queue longer than `aging` is taken before any non-aged job (oldest first),
//     so no job starves even when tiny k lets fetch-free jobs fill every window.
#pragma once
#include <algorithm>
#include <array>
#include <limits>
#include <memory>
#include <vector>

#include "sched/policy/gmb/arrival_bound.hpp"
#include "sched/policy/gmb/bucket_order.hpp"
#include "sched/policy/gmb/plan_cells.hpp"
#include "sched/sdc/fetch_bound.hpp"
#include "sched/policy/placer.hpp"
#include "sched/policy/scheduler.hpp"

namespace rayline {

struct GmbOptions {
  Time horizon = 2.0;         // k, seconds (the paper uses 2000 ms)
  Time aging = -1;            // seconds a job may wait before it jumps the queue; <0: 5k (min 1 s); kNever: off
  // Rayline's option: the aging threshold is at least twice the median wait of the queued
  // jobs at each plan (only outliers jump the queue when every job waits).
  bool adaptive_aging = false;
  bool granularity_tiebreak = true;
  // Rayline's refinement (off = the paper's GMB): a job that would have to wait for a
  // fetch on the chosen device is left for another device that would *finish* it sooner
  // (earliest completion, as in HEFT/min-min), so a slow or data-less device stops
  // grabbing work. Measured against the exhaustive optimum in test_gmb_properties.
  bool completion_aware = false;
  // Tests and benchmarks only: select with the straightforward pruned scan (bounds of every
  // bucket recomputed and sorted at every step) instead of the incremental per-memory-device
  // index; both choose identically (test_gmb_equivalence).
  bool reference_selection = false;
  // Rayline's option (planning speed at scale, plan_cells.hpp): plan in cells of at most
  // this many nodes; a device considers only the jobs homed in its cell. <= 0: one cell
  // (the paper's GMB). A platform of at most this many nodes is one cell either way.
  int cell_nodes = 0;
};

// The SDC fetch-path searches (Eq. 3) of one plan() call: searches run, answers the
// finder's cache gave without one, and searches stopped early (at the destination, or
// once every label lost).
struct GmbSearchStats {
  std::uint64_t path_searches = 0, path_cache_hits = 0, path_cut_searches = 0;
};

class GmbScheduler final : public Scheduler {
 public:
  explicit GmbScheduler(GmbOptions opt = {}) : opt_(opt) {}
  std::string name() const override { return "gmb"; }
  std::string describe() const override;
  PlanStats plan(Time now, JobPool& pool, Schedule& schedule) override;
  // One cell (the paper's GMB): yes. In plan cells, some device of a large cluster is
  // always idle, and a plan at every event would mostly find nothing new to place.
  bool plans_while_idle() const override { return cells_.flat(); }
  const GmbOptions& options() const { return opt_; }
  Time aging_threshold() const;
  const GmbSearchStats& last_search_stats() const { return search_stats_; }
  const PlanCells& cells() const { return cells_; }

 private:
  struct Choice {
    JobId job = kNone;
    Time start = kNever;     // (kNever while job is kNone)
    double granularity = 0;  // T_SETUP / T_EXEC
    bool aged = false;
    Time created = 0;
    Time sure_loss = kNever;  // set_start(): a later time above it surely loses (see gmb_scheduler.cpp)
    void set_start(Time t) {
      start = t;
      sure_loss = t + 1e-11 * std::max(1.0, t < 0 ? -t : t);
    }
    // Would a job starting at t lose to this one (later, and not within nearly_equal())?
    // False while there is no job.
    bool loses(Time t) const { return t > start && (t > sure_loss || !nearly_at_start(t)); }
    bool nearly_at_start(Time t) const;
  };
  Choice select(DeviceId d, Time ready, Time now, const JobPool& pool, const Schedule& s);
  Choice evaluate(JobId j, DeviceId d, Time ready, Time now, const JobPool& pool, const Schedule& s);
  bool better_elsewhere(const Choice& c, DeviceId d, const JobPool& pool, const Schedule& s);
  bool commit(const Choice& c, DeviceId d, Time ready, Time now, JobPool& pool, Schedule& s, PlanStats& st);

  GmbOptions opt_;
  GmbSearchStats search_stats_;
  const Schedule* bound_ = nullptr;
  // The platform the graph-only parts (FetchBound's all-pairs minima, ArrivalBound's
  // bandwidths, the finder's buffers) were built for: kept while one GmbScheduler plans
  // successive Schedules of the same platform (the runtime loop's steady state).
  std::uint64_t graph_print_ = 0;
  std::array<std::size_t, 4> graph_shape_{};  // plan(): the graph last fingerprinted (address, sizes)
  std::uint64_t graph_shape_print_ = 0;
  static std::uint64_t fingerprint(const DeviceGraph& g);
  std::unique_ptr<Placer> placer_;
  PlanCells cells_;
  std::unique_ptr<FetchBound> bound_time_;
  std::vector<std::pair<JobId, MemId>> blocked_pairs_;  // sorted: infeasible this round (capacity)
  std::vector<JobId> deferred_;  // completion_aware: jobs left to other devices this placement
  bool deferred(JobId j) const {
    return !deferred_.empty() && std::find(deferred_.begin(), deferred_.end(), j) != deferred_.end();
  }
  // Selection index (rebuilt each plan call): queued jobs grouped by their largest input
  // ("key" block). A job cannot start before its key block is on the device's memory, so
  // a bucket whose lower bound already loses to the best candidate is skipped whole.
  struct Bucket {
    BlockId key;
    std::vector<JobId> jobs;  // queue order
    int queued = 0;           // of them still queued
  };
  std::vector<Bucket> buckets_;
  std::vector<std::vector<JobId>> spare_jobs_;  // buckets' job lists of earlier plans (capacity kept)
  std::vector<std::int32_t> bucket_of_block_, bucket_of_job_;
  std::vector<JobId> indexed_jobs_;  // the jobs bucket_of_job_ holds this pass
  std::vector<std::pair<Time, std::int32_t>> order_;
  Time aging_now_ = kNever;     // build_index(): the aging threshold of this plan
  std::vector<Time> ages_;
  std::vector<JobId> aged_;     // build_index(): queued jobs past the aging threshold, oldest first
  std::size_t aged_head_ = 0;   // aged_[0, aged_head_) are planned
  void build_index(Time now, const JobPool& pool);
  // Reference selection: every bucket's bound recomputed and sorted at every step.
  Choice select_pruned(DeviceId d, Time ready, Time now, const JobPool& pool, const Schedule& s);
  // SDC's cut search (FetchPathFinder::arrival_within) answers for b at m: b may move and
  // fits in m. Otherwise the tree's arrival() is asked.
  static bool cut_searchable(const Schedule& s, BlockId b, MemId m) {
    const DataBlock& blk = s.pool().block(b);
    return blk.movable && s.graph().memories[static_cast<std::size_t>(m)].capacity >= blk.bytes;
  }
  // Incremental selection (same choice): per memory device, a persistent order of holder
  // groups of buckets (arrival_bound.hpp) keyed by lower bounds that commits can only make
  // stale from below (bucket_order.hpp); within a group, buckets smallest key block first;
  // within a bucket, jobs in granularity order per device timing class, stopping at the
  // first that starts as early as the key block allows.
  Choice select_indexed(DeviceId d, Time ready, Time now, const JobPool& pool, const Schedule& s);
  void evaluate_bucket(std::int32_t i, DeviceId d, MemId m, Time ready, Time now, const JobPool& pool,
                       const Schedule& s, Choice& best);
  Time group_key(std::int32_t g, MemId m, Time now, const Schedule& s);
  template <class Loses>
  Time fold_input(BlockId b, MemId m, Time start, Time now, const Schedule& s, const Loses& loses, Time& lost_at);
  // Per job: the last lower bound on its start, from one non-key input that lost on one
  // memory device (that input's SDC arrival or a bound on it), valid while the input's
  // holders are unchanged (within a pass costs only grow). A job whose floor on m still
  // loses is passed over unevaluated.
  struct InputFloor {
    Time lb = -kNever;
    BlockId block = kNone;
    MemId m = kNone;
    std::uint64_t holders = 0;
  };
  std::vector<InputFloor> floors_;  // per job id
  std::vector<JobId> floor_jobs_;   // the jobs with a floor this pass
  bool visit_group(std::int32_t g, DeviceId d, MemId m, Time ready, Time now, const JobPool& pool,
                   const Schedule& s, Choice& best);
  // After a commit (or a failed one that left hops): re-group the blocks it moved.
  void after_commit(std::size_t activities_before, std::size_t evictions_before, const JobPool& pool,
                    const Schedule& s);
  std::int32_t no_key_bucket_ = -1;  // jobs without inputs
  std::vector<BlockId> keys_;        // plan(): the buckets' key blocks, for ArrivalBound
  // Per bucket and memory device: queued jobs not blocked there (blocked is for the plan).
  std::vector<std::int32_t> open_;
  std::int32_t open(std::int32_t i, MemId m) const {
    return open_[static_cast<std::size_t>(i) * mem_index_.size() + static_cast<std::size_t>(m)];
  }
  bool prefer(const Choice& c, const Choice& best) const;
  // prefer(), flagging near-ties. Inline: the two answers that need no tolerance test (c
  // starts clearly earlier; the same start and granularity), then the full comparison.
  bool prefer_checked(const Choice& c, const Choice& best) {
    if (best.job != kNone && !c.aged && !best.aged) {
      if (best.start > c.sure_loss) return true;
      if (c.start == best.start && c.granularity == best.granularity) return c.job < best.job;
    }
    return prefer_checked_full(c, best);
  }
  bool prefer_checked_full(const Choice& c, const Choice& best);
  struct MemIndex {
    bool built = false;
    BucketOrder order;
  };
  std::vector<MemIndex> mem_index_;
  std::vector<char> group_seen_;  // select_indexed(): groups already entered in a new order
  std::unique_ptr<ArrivalBound> arrival_bound_;  // bounds from exact arrivals seen so far
  // Device timing classes (identical coefficients for every job type) and, per bucket and
  // class, the bucket's jobs sorted by (T_SETUP/T_EXEC, id) -- built on first use.
  std::vector<std::int32_t> class_of_device_;
  std::int32_t classes_ = 0;
  struct Sorted {
    bool built = false;
    bool monotone = true;  // no two granularities within nearly_equal but different
    std::vector<std::pair<double, JobId>> jobs;
    // jobs[0, head) are planned: within a pass a job leaves the queue for good, and the
    // front of the order is what gets planned first (a long run's lists were half planned
    // jobs, each weighed again at every selection).
    std::size_t head = 0;
  };
  std::vector<Sorted> sorted_;  // bucket x cell x class (never shrunk: the lists keep their capacity)
  std::vector<DeviceId> class_reps_;  // build_classes(): one device per class
  std::vector<unsigned char> class_coef_;  // the bytes of the coefficients they were built from
  std::vector<std::pair<Time, DeviceId>> device_queue_;  // plan(): devices by ready time (a min-heap)
  void build_classes(const Schedule& s);
  const Sorted& sorted_jobs(std::int32_t i, DeviceId d, MemId m, const JobPool& pool, const Schedule& s);
  double granularity(JobId j, DeviceId d, const JobPool& pool, const Schedule& s);
  bool near_tie_ = false;
  Time now_ = 0;
};

}  // namespace rayline

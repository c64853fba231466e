// Schedule (Sec. 4.1, Fig. 4): one Timeline per compute device and per channel resource,
// the E-jobs and T-jobs committed onto them (Activities), and where every data block is
// held, from when, under each memory device's capacity.
//
// Timelines are append-only, as in the paper: a new activity starts no earlier than the
// end of the last one on its timeline (FinishTime(c) in Eq. 3). Activities only ever
// depend on activities committed before them, so increasing ActivityId is a topological
// order; reproject() uses that to move every unfinished activity after reality diverged.
#pragma once
#include <algorithm>
#include <array>
#include <string>
#include <unordered_map>
#include <vector>

#include "sched/timeline/activity_list.hpp"
#include "sched/timeline/chunked_store.hpp"
#include "sched/core/device_graph.hpp"
#include "sched/core/job_pool.hpp"

namespace rayline {

enum class ActivityKind : std::uint8_t { Exec, Transfer };
enum class ActivityState : std::uint8_t { Planned, Running, Done, Failed };

struct Activity {
  ActivityKind kind = ActivityKind::Exec;
  ActivityState state = ActivityState::Planned;
  JobId job = kNone;           // Exec: the E-job. Transfer: the E-job it fetches for.
  BlockId block = kNone;       // Transfer: the block moved or copied
  DeviceId device = kNone;     // Exec
  ChannelId channel = kNone;   // Transfer
  bool move = false;           // Transfer: source copy dropped at the end (ray queues)
  Bytes bytes = 0;             // Transfer: |w|
  Time duration = 0;           // predicted: Eq. 1 or Eq. 2
  Time setup = 0;              // Exec: T_SETUP part of duration
  Time planned_start = 0, planned_end = 0;  // as committed (never changed afterwards)
  Time start = 0, end = 0;     // projected; the measured values once known
  Time data_ready = 0;         // Exec: when every input was resident (fetching idle, Sec. 4.2)
  bool cancelled = false;      // withdrawn by Schedule::cancel: runs for 0 s, moves nothing
  // Aborted by Schedule::fail before it started: it keeps its place on its timelines and
  // ends (0 s, silently) once its timeline predecessors have; its dependencies are dropped.
  bool placeholder = false;
  ActivityList deps;           // data / eviction / job-job dependencies
  ActivityList timeline_prev;  // predecessor on each of its timelines
};

// A copy of a block on a memory device (the holders of Sec. 4.4).
struct Copy {
  MemId mem = kNone;
  ActivityId producer = kNone;  // Transfer or Exec that creates it; kNone: present initially
  Time initial_ready = 0;       // for producer == kNone
  ActivityList users;             // E-jobs reading it and T-jobs sending it (usually <= 3)
  bool origin = false;          // the block's home (never evicted)
};

// Why a copy was evicted: the plan explains itself (eviction is a decision).
struct Eviction {
  BlockId block;
  MemId mem;
  Time at;                 // the end of the copy's last planned use
  ActivityId for_activity; // the transfer/E-job that needed the space
  int queued_demand;       // queued jobs still reading the block when it was chosen
  std::string reason;
  std::vector<ActivityId> after;  // the copy goes once these end (its producer and users)
};

struct Timeline {
  std::vector<ActivityId> items;
  Time busy_until = 0;     // FinishTime of the timeline (projected)
};

class Schedule {
 public:
  Schedule(const DeviceGraph& graph, const JobPool& pool);

  const DeviceGraph& graph() const { return *graph_; }

  // Eviction order: Rayline's default (bytes already leaving, then copies the queue wants
  // least, then whose last planned use ends first), or plain LRU (last use first, ignoring
  // the queue) for baselines that model LRU caches (Budge 2009).
  enum class EvictionPolicy : std::uint8_t { QueueAware, Lru };
  void set_eviction_policy(EvictionPolicy p) { eviction_policy_ = p; }
  // admission() keeps each device's leaving entries sorted while no activity's end moves
  // (the default). Off: it sorts them afresh at every call, the reference the kept order
  // is tested against (the same admissions either way).
  void set_kept_leaving_order(bool on) { kept_leaving_order_ = on; }
  const JobPool& pool() const { return *pool_; }
  // After copying a Schedule together with its JobPool, point the copy at the new pool.
  void rebind(const JobPool& pool) { pool_ = &pool; }

  // Data placement. Initial copies: put(b, m, ready_time, origin).
  void put_initial(BlockId b, MemId m, Time ready = 0, bool origin = true);
  const std::vector<Copy>& copies(BlockId b) const {
    return static_cast<std::size_t>(b) < copies_.size() ? copies_[static_cast<std::size_t>(b)] : no_copies_;
  }
  const Copy* copy_at(BlockId b, MemId m) const {
    if (static_cast<std::size_t>(b) >= copies_.size()) return nullptr;
    if (static_cast<std::uint32_t>(m) < 64u && !((holder_mask_[static_cast<std::size_t>(b)] >> m) & 1)) return nullptr;
    const std::vector<Copy>& cs = copies_[static_cast<std::size_t>(b)];
    if (cs.size() > kScannedCopies) return indexed_copy_at(b, m);
    for (const Copy& c : cs)
      if (c.mem == m) return &c;
    return nullptr;
  }
  // For a block with more than kScannedCopies copies (else {0, 0}): how many copies lead
  // copies(b) as initial copies ready at the same time (producer kNone: a scene block on
  // every disk), and a stamp that changes whenever that prefix does. Bounds over those copies can be kept while
  // the stamp holds, however often the block's other holders change.
  struct CopyPrefix {
    std::size_t count = 0;
    std::uint64_t stamp = 0;
  };
  CopyPrefix initial_prefix(BlockId b) const;
  // For such a block: per memory device, the index of its copy in copies(b) (-1: none);
  // nullptr for a block with few copies. Valid until the block's holders change.
  const std::int32_t* copy_positions(BlockId b) const;
  static constexpr std::size_t kScannedCopies = 16;
  Time copy_ready(const Copy& c) const {
    return c.producer == kNone ? c.initial_ready : acts_[c.producer].end;
  }
  // Bytes reserved on m (present, incoming, or leaving at a planned time).
  Bytes used(MemId m) const { return used_[m]; }
  // Per node: moves whenever something on it changes: an activity on its compute devices,
  // or on a channel from or to its memories, is committed, starts, ends, is cancelled,
  // retimed or aborted; a copy on its memories comes, goes, or its room is freed. A policy
  // that plans node by node (Rayline's) asks a node again only when this moved or time did.
  std::uint64_t node_epoch(NodeId n) const {
    return static_cast<std::size_t>(n) < node_epoch_.size() ? node_epoch_[static_cast<std::size_t>(n)] : 0;
  }
  std::uint64_t holders_version(BlockId b) const {
    return static_cast<std::size_t>(b) < holders_version_.size() ? holders_version_[b] : 0;
  }

  // Timelines.
  const Timeline& device_timeline(DeviceId d) const { return device_tl_[d]; }
  const Timeline& resource_timeline(ResourceId r) const { return resource_tl_[r]; }
  // FinishTime(c) of Eq. 3: the latest busy-until of c's resources (kept per channel, updated
  // when a resource's timeline changes).
  // A lost channel (fail()) is busy for ever: no Eq. 3 label crosses it.
  // A channel on a resource that many channels share (a NIC of a large network, a rack
  // uplink, a backbone) is computed when asked instead: keeping it would cost every
  // booking of that resource one update per channel on it (N² for a backbone).
  Time channel_finish(ChannelId c) const {
    const auto ci = static_cast<std::size_t>(c);
    if (!dead_channel_.empty() && dead_channel_[ci]) return kNever;
    if (!on_demand_.empty() && on_demand_[ci]) return channel_finish_now(c);
    return channel_finish_[ci];
  }
  Time channel_finish_now(ChannelId c) const {
    Time t = 0;
    for (ResourceId r : on_demand_route_[static_cast<std::size_t>(c)]) t = std::max(t, resource_tl_[r].busy_until);
    return t;
  }
  std::uint64_t resource_version(ResourceId r) const { return resource_version_[r]; }

  // Activities.
  std::size_t activity_count() const { return acts_.size(); }
  const Activity& activity(ActivityId a) const { return acts_[a]; }
  const std::vector<Eviction>& evictions() const { return evictions_; }

  // ---- committing (used by schedulers) --------------------------------------------
  // Earliest time `bytes` more fit on m, evicting cached copies if needed; kNever when
  // impossible. `keep` lists blocks that must not be evicted (the job's own inputs).
  struct Admission {
    Time at = 0;
    std::vector<std::pair<BlockId, MemId>> victims;  // copies to evict
    std::vector<Time> victim_at;                     // per victim: its last planned use ends
    std::vector<ActivityId> wait_for;                // activities that must end first
    // Bytes already leaving m that the incoming data counts on: (index into the leaving
    // list, bytes taken). Only these are handed over; the rest stays reserved until it goes.
    struct Taken { std::uint32_t leaving; BlockId block; Bytes bytes; };
    std::vector<Taken> taken;
    // Room the last victim frees beyond what is needed: it is free only once that copy's
    // producer and users end, so it stays reserved until then (a new leaving entry).
    Bytes victim_surplus = 0;
  };
  Admission admission(MemId m, Bytes bytes, const std::vector<BlockId>& keep) const;

  // Appends a T-job moving/copying b over channel c, starting no earlier than `not_before`
  // (Eq. 3: max(l_p, FinishTime(c))) after applying `adm`. Returns its id.
  ActivityId commit_transfer(BlockId b, ChannelId c, JobId for_job, Time not_before, const Admission& adm);
  // Appends an E-job; inputs must already be (or be arriving) on the device's memory.
  ActivityId commit_exec(JobId j, DeviceId d, Time not_before, const Admission& out_adm);

  // ---- withdrawing (used by workloads) ----------------------------------------------
  // Sec. 5.2: a predicted job whose parent produced nothing for it is "discarded with its
  // T-jobs". cancel() withdraws one Planned (not yet started) activity when nothing else
  // counts on what it produces: a T-job that copies (never one that moves a ray queue)
  // and whose destination copy no live activity uses; an E-job that consumes no input and
  // whose outputs no live activity uses. Its copies disappear from the plan at once, but
  // their bytes stay reserved until the activity "finishes"; it keeps its dependencies
  // and its place on its timelines and runs for 0 s, so executors complete it as soon as
  // what it waited for is done, and reproject() pulls its successors forward. Evictions
  // made for it stand (they were decided; the room is simply free). Returns false, and
  // changes nothing, when the activity is not withdrawable.
  bool cancel(ActivityId a);
  // Withdraws job j's E-job, then its T-jobs, last hop first (each one's copy is used by
  // the next), keeping those another activity still needs.
  struct CancelCount { int execs = 0, transfers = 0, kept_transfers = 0; Bytes bytes = 0; };
  CancelCount cancel_job(JobId j);
  // A Planned E-job whose input grew after commit (rays merged into its queue, Sec. 5.1)
  // runs `duration` (Eq. 2 for the new sizes): its end moves, and reproject() moves what
  // follows it, so the plan stays true to what will run. Returns false unless Planned.
  bool retime(ActivityId a, Time duration);
  // T-jobs committed to fetch inputs for job j (commit order).
  const ActivityList& transfers_for(JobId j) const;

  // ---- reality (used by the runtime loop) -------------------------------------------
  void on_started(ActivityId a, Time t);
  void on_finished(ActivityId a, Time t);
  // Moves every unfinished activity to the earliest time consistent with the measured
  // ones and `now` (reality wins, docs/architecture.md), updating busy_until of every timeline.
  void reproject(Time now);
  std::size_t unfinished_on_device(DeviceId d) const { return device_pending_[d]; }
  std::size_t unfinished() const { return unfinished_; }

  // ---- faults (docs/faults.md) ------------------------------------------------------
  // Devices lost at `now` (for good): compute devices, and memory devices with the data on
  // them (a lost memory takes the compute devices attached to it, and every channel to or
  // from it). `seeds` are activities that failed on their own (a block read returning an
  // I/O error). Every unfinished activity on a lost device or channel, every seed, and
  // every activity that waits for one of them (its deps, transitively) is aborted: it
  // moves nothing and produces nothing, and a copy it was to consume or move away is
  // still where it was (unless that memory is lost). The plan stays append-only: aborted
  // activities keep their ids and places, marked Failed and withdrawn (they end at now).
  struct Failure {
    std::vector<ActivityId> aborted;  // in id order
    std::vector<JobId> jobs;          // jobs whose E-job was aborted: to be queued again
    std::vector<BlockId> lost;        // blocks whose last copy was on a lost memory
  };
  Failure fail(Time now, const std::vector<ActivityId>& seeds, const std::vector<DeviceId>& computes,
               const std::vector<MemId>& memories);
  bool compute_alive(DeviceId d) const { return dead_compute_.empty() || !dead_compute_[static_cast<std::size_t>(d)]; }
  bool memory_alive(MemId m) const { return dead_memory_.empty() || !dead_memory_[static_cast<std::size_t>(m)]; }
  bool channel_alive(ChannelId c) const { return dead_channel_.empty() || !dead_channel_[static_cast<std::size_t>(c)]; }
  bool any_lost() const { return !dead_compute_.empty(); }

  // Ends of the activities of `after` jobs, kNever if one is not planned yet.
  Time after_deps_ready(JobId j) const {
    Time t = 0;
    for (JobId p : pool_->job(j).after) {
      const ActivityId a = pool_->activity(p);
      if (a == kNone) return kNever;
      t = std::max(t, acts_[static_cast<std::size_t>(a)].end);
    }
    return t;
  }

 private:
  void evict(BlockId b, MemId m, Time at, ActivityId for_activity, const std::string& reason);
  // `what` names what needs the room (for the eviction reasons); built only when evicting.
  template <class What>
  void apply_evictions(const Admission& adm, MemId m, ActivityId for_activity, const What& what);
  Copy* mutable_copy(BlockId b, MemId m);
  void add_copy(BlockId b, Copy c);
  void drop_copy_later(BlockId b, MemId m, ActivityId leaving_with);
  bool withdraw_copy(BlockId b, MemId m, ActivityId producer);
  static void forget_user(Copy* c, ActivityId a);
  Time end_of(ActivityId a) const { return a == kNone ? 0 : acts_[a].end; }

  const DeviceGraph* graph_;
  const JobPool* pool_;
  ChunkedStore<Activity> acts_;
  std::vector<Timeline> device_tl_, resource_tl_;
  std::vector<Time> channel_finish_;  // per channel: max(0, busy_until of its resources)
  static constexpr std::int32_t kKeptFanout = 64;  // channels per resource above which its channels are on demand
  std::vector<char> on_demand_;       // per channel (empty: none): channel_finish_now() when asked
  static constexpr std::size_t kRouteMax = 5;  // resources of an on-demand channel (a route through racks has 5)
  // Per channel (with on_demand_): its resources, the first repeated to fill the array
  // (a maximum is unchanged by repeats), read without the DeviceGraph's indirection.
  std::vector<std::array<ResourceId, kRouteMax>> on_demand_route_;
  // Channels using each resource (CSR: channels_of_resource_[first_..[r+1])).
  std::vector<std::int32_t> resource_channels_first_;
  std::vector<ChannelId> resource_channels_;
  void resource_busy_changed(ResourceId r);
  // The same after r's busy_until was raised to t (and no other resource changed): each
  // channel on r finishes at the larger of what it did and t.
  void resource_busy_raised(ResourceId r, Time t);
  std::vector<std::uint64_t> resource_version_, holders_version_;
  std::vector<std::uint64_t> node_epoch_;  // node_epoch()
  void touch_node(NodeId n) {
    if (n == kNone) return;
    if (static_cast<std::size_t>(n) >= node_epoch_.size()) node_epoch_.resize(static_cast<std::size_t>(n) + 1, 0);
    ++node_epoch_[static_cast<std::size_t>(n)];
  }
  void touch_memory(MemId m) { touch_node(graph_->memories[m].node); }
  void touch(const Activity& a);  // the nodes a's device or channel belongs to
  std::vector<std::vector<Copy>> copies_;          // per block (grows with the pool)
  // Per memory device: the blocks that may be cache there (neither consumed nor pinned) and
  // had a copy there, ascending; admission() reads only these and drops the ones gone
  // (every block of a long run was hundreds of thousands to walk per eviction).
  mutable std::vector<std::vector<BlockId>> cache_candidates_;
  void note_cached(BlockId b, MemId m);
  static inline const std::vector<Copy> no_copies_{};
  // Per block: bit m set iff a copy is on memory device m < 64 (copy_at's quick miss; a
  // device >= 64 is always looked up).
  std::vector<std::uint64_t> holder_mask_;
  // A block with more than kScannedCopies copies (a scene block on every disk of a large
  // cluster) is looked up through a position index per memory device, rebuilt when its
  // holders version moved: copy_at() is asked per memory device and relay, so a scan
  // would make fetch-path searches quadratic in the node count.
  struct CopyIndex {
    std::uint64_t holders = ~std::uint64_t{0};
    std::vector<std::int32_t> pos;  // per memory device: index into copies_[b], -1: none
    CopyPrefix prefix;
  };
  mutable std::unordered_map<BlockId, CopyIndex> copy_index_;
  CopyIndex& copy_index(BlockId b) const;  // rebuilt if the holders version moved
  const Copy* indexed_copy_at(BlockId b, MemId m) const;
  void forget_holder(BlockId b, MemId m) {
    if (static_cast<std::uint32_t>(m) < 64u) holder_mask_[static_cast<std::size_t>(b)] &= ~(std::uint64_t{1} << m);
  }
  std::vector<Bytes> used_;                        // per memory device
  // Copies leaving (consumed or moved away) at the end of an activity, or the unneeded
  // part of an evicted copy: their bytes stay reserved until every activity of `after`
  // has ended; admission may count on them from then on, and whoever does waits for them.
  // `dropped_by`: the consumer or move that takes the copy away (kNone: an eviction's or a
  // withdrawal's reserve); `producer`: the copy's producer then, to put it back when that
  // activity is aborted (fail()).
  struct Leaving {
    BlockId block;
    MemId mem;
    ActivityList after;
    Bytes bytes;
    ActivityId dropped_by = kNone;
    ActivityId producer = kNone;
    Time ready = 0;  // the copy's ready time (producer kNone)
    std::uint64_t serial = 0;  // increasing in the order entries are made
  };
  Time leaving_at(const Leaving& l) const;
  // Per memory device, in the order they were made (admission() reads only its device's).
  // An entry whose activities have all ended is dead (`after` empty, no bytes) until the
  // next compaction of its device's list (when the dead are half of it).
  std::vector<std::vector<Leaving>> leaving_;
  std::vector<std::size_t> dead_leaving_;  // per memory device
  std::uint64_t next_leaving_serial_ = 0;
  Leaving& add_leaving(Leaving l);
  // admission()'s order of a device's live leaving entries, (leaving_at, block, serial),
  // kept while no activity's end moves (ends_epoch_): a full device under a long plan holds
  // thousands of entries, and one plan asks for room there hundreds of times. Entries made
  // since it was sorted wait, sorted, in `recent` until they are many. An entry gone or
  // dead since is skipped where it is met.
  struct LeavingKey {
    Time at;
    BlockId block;
    std::uint64_t serial;
    bool operator<(const LeavingKey& o) const {
      if (at != o.at) return at < o.at;
      if (block != o.block) return block < o.block;
      return serial < o.serial;
    }
  };
  struct LeavingOrder {
    std::uint64_t epoch = ~std::uint64_t{0};
    std::uint64_t next_serial = 0;  // entries with a serial below this are sorted in
    std::size_t head = 0;           // sorted's keys before it are dropped
    std::vector<LeavingKey> sorted, recent;
  };
  mutable std::vector<LeavingOrder> leaving_order_;
  bool kept_leaving_order_ = true;
  std::uint64_t ends_epoch_ = 0;  // moves whenever a planned or running activity's end may
  LeavingOrder& leaving_order(MemId m) const;  // brought up to date
  template <class List>
  static auto first_leaving(List& lv, std::uint64_t serial);
  // Per activity, the entries that wait for it (a list through wait_nodes_, head per
  // activity): on_finished visits those alone, not every entry of the run.
  struct WaitNode {
    MemId mem;
    std::uint64_t serial;
    std::int32_t next;
  };
  std::vector<WaitNode> wait_nodes_;
  std::vector<std::int32_t> wait_head_;
  void wait_for_end(Leaving& l, ActivityId a);
  std::vector<Eviction> evictions_;
  // Per producer whose copy was evicted while activities still read it: those readers.
  // Evicting the copy does not make its producer withdrawable (cancel()): they still need
  // what it delivers (found by 36 000 random withdrawing runs).
  std::unordered_map<ActivityId, ActivityList> evicted_readers_;
  bool read_after_eviction(ActivityId producer) const;
  std::vector<ActivityList> job_transfers_;  // per JobId: its T-jobs
  std::vector<std::size_t> device_pending_;
  std::size_t unfinished_ = 0;
  EvictionPolicy eviction_policy_ = EvictionPolicy::QueueAware;
  std::vector<ActivityId> pending_;  // activities not known to be done, in id order (reproject)
  // reproject() of a waiting activity with many dependencies (an E-job of thousands of
  // merged ray queues): the ones not seen done yet, and the latest end of those that were
  // (a done activity's end is final), so each dependency is read done only once.
  struct OpenDeps {
    std::uint32_t of_size = 0;  // deps.size() it was made from (rebuilt if that changes)
    Time done_end = -kNever;
    std::vector<ActivityId> open;
  };
  std::unordered_map<ActivityId, OpenDeps> open_deps_;
  Time latest_dep_end(ActivityId id, const Activity& a);
  std::vector<char> dead_compute_, dead_memory_, dead_channel_;  // empty until the first fault
};

}  // namespace rayline

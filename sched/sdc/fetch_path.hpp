// Smallest Datapath Contention (SDC, Sec. 4.4, Eq. 3): the earliest time a data block can
// reach each memory device given the current schedule. Dijkstra from a virtual source S
// joined to every holder m of the block by an edge weighted with the copy's ready time;
// relaxing channel c_pq gives
//     l_{S->q} = max(l_{S->p}, FinishTime(c_pq)) + T_TRANS(c_pq, |w|)        (Eq. 3)
// One run yields a shortest-path tree to every memory device, so results are cached per
// block and invalidated only by what a commit changes: the block's holders (versioned by
// the Schedule), or the busy-until of a resource on the path to a destination. Each
// destination keeps the sum of the Schedule's resource versions along its path at search
// time; versions only grow, so the destination is still valid iff the sum is unchanged
// (no reverse index, nothing to push: a commit invalidates exactly the destinations whose
// path crosses a resource it booked). Within one planning pass costs never decrease, so a
// path none of whose edges changed stays optimal.
//
// The arrival time itself does not depend on which search found it: every edge function
// max(l, F) + T is monotone in l (also in floating point), so Dijkstra's label is the
// minimum over all admissible paths of the path's Eq. 3 chain, evaluated with the same
// operations. arrival_within() uses that to answer GMB's question "does b reach m by
// `enough`, and if not, exactly when, unless that already loses" with a search cut at the
// losing labels and stopped at m (planning speed): the same value as arrival(),
// usually after a handful of relaxations, and no tree is stored.
//
// Networks (planning speed at scale): a member's RAM has one channel to every other
// member, so a search that relaxed them one by one would cost O(nodes) per label. The
// search meets them in runs (one network's channels out of p to one group: a rack, or
// the whole network without racks) and decides per run from a floor on what any of its
// hops could give (FetchBound::network_floor: Eq. 3 on the resources the run's channels
// share, the uncontended rest, the last hop into m, and the rack cut): a run that cannot
// beat m's label, or that loses, is skipped whole; the floor only removes hops that could
// not change m's label, so every answer is the same. The relayed last hops into m are
// scanned in the same runs (FetchBound::relay_min).
//
// Capacity is not part of the search (it would invalidate every tree reaching the
// memory device that just received data); the scheduler applies admission delays when it
// commits the hops. Memory devices smaller than the block are skipped.
#pragma once
#include <algorithm>
#include <limits>
#include <span>
#include <unordered_map>
#include <vector>

#include "sched/sdc/fetch_bound.hpp"
#include "sched/timeline/schedule.hpp"

namespace rayline {
class FetchPathFinder {
 public:
  explicit FetchPathFinder(const Schedule& schedule);

  // Earliest arrival of block b at m; kNever when no path (or b has no holder).
  Time arrival(BlockId b, MemId m);
  // Channels of the best path to m, source first (empty if b is already on m).
  void path(BlockId b, MemId m, std::vector<ChannelId>& out);

  // The SDC arrival a = arrival(b, m), asked by a selection that only needs max(enough, a)
  // and discards it when it is `lost`. `lost` must be monotone (lost(x) implies lost(y) for
  // y >= x) and !lost(enough) (enough may be -inf). Returns x with
  //     x <= enough         when a <= enough,
  //     x == a              when enough < a and !lost(a),
  //     x == kNever         when lost(a) (then *proven, if given, is a lower bound on a).
  // With x == a, *hops (if given) is the number of hops of a best path (kMemoHops + 1: more).
  // Answers from a valid memo or cached tree when it can; otherwise a branch-and-bound
  // search (cut_search) that never expands a lost label and stops once nothing open can
  // beat m's label. The answer is memoised per (b, m): an exact arrival while the resources
  // on its path and b's holders are unchanged, a lower bound while b's holders are
  // unchanged (costs only grow within a planning pass). No tree is stored.
  template <class Lost>
  Time arrival_within(BlockId b, MemId m, Time enough, const Lost& lost, Time* proven = nullptr, int* hops = nullptr) {
    // (Inline: a ray queue is usually answered by its first hop, single_holder_direct().)
    bool single = false;  // single_holder_direct() applied (and left it open)
    if (!hops && !restricted(b)) {
      const Time a = single_holder_direct(b, m, true, nullptr, &single);
      if (a == a) {  // (NaN: not settled that way)
        if (a <= enough || !lost(a)) return a;
        if (proven) *proven = a;
        return kNever;
      }
    }
    return arrival_within_open(b, m, enough, lost, proven, hops, single);
  }
  static constexpr int kMemoHops = 4;
  // What arrival_within() has proved so far: a lower bound on arrival(b, m) (-inf: none).
  Time known_lower_bound(BlockId b, MemId m) const {
    const auto bi = static_cast<std::size_t>(b);
    if (bi >= memo_slot_.size() || memo_slot_[bi] < 0) return -kNever;
    const std::int32_t k = memo_index_[static_cast<std::size_t>(memo_slot_[bi]) * n_ + static_cast<std::size_t>(m)];
    if (k < 0) return -kNever;
    const Memo& e = memos_[static_cast<std::size_t>(k)];
    return e.holders == schedule_->holders_version(b) ? e.lb : -kNever;
  }

  // Lower bounds on the remaining way to a destination that order and cut those searches
  // (GMB sets its FetchBound; without, the searches run in Dijkstra's order). With bounds
  // set, path() takes the best path from one such search when no other path ties with it
  // anywhere along it (then every search finds this path), else from the full tree.
  void set_bounds(const FetchBound* rest) {
    if (rest == rest_ && runs_built_) return;  // the runs depend on the graph and the bounds only
    if (rest != rest_) prefix_roots_.clear();
    rest_ = rest;
    build_runs();
  }

  void clear();                         // after reproject(): everything may have moved
  // Search another Schedule on the same platform (same memory devices and channels),
  // keeping the buffers; nothing cached survives.
  void rebind(const Schedule& schedule);
  // Transfers cannot start in the past: a holder's edge from S weighs max(ready, now).
  void set_now(Time now) { if (now != now_) { now_ = now; clear(); } }
  // Baselines that never send scene data between nodes (GraviT compiles SEND_DOMS out):
  // SceneData then starts from the destination node's own copies when it has any, else
  // from origin copies (a central scene database), never from another node's cache.
  void set_scene_from_origin_or_local(bool on) {
    if (on != scene_local_) { scene_local_ = on; clear(); }
  }
  bool scene_from_origin_or_local() const { return scene_local_; }
  // Whether b's roots depend on the destination's node (scene data under the rule above);
  // every other block starts from all its holders, memoised and short-cut as usual.
  bool restricted(BlockId b) const {
    return scene_local_ && schedule_->pool().block(b).kind == DataKind::SceneData;
  }

  std::uint64_t searches() const { return searches_; }
  std::uint64_t hits() const { return hits_; }
  std::uint64_t cut_searches() const { return cut_searches_; }  // arrival_within() without a tree
  // search() may stop before settling its destination once that label is final, checked
  // every `settled` devices it settles (default 64; 0: never, plain Dijkstra to the
  // destination, the tests' reference).
  void set_early_stop(std::size_t settled) { early_stop_ = settled; }
  std::uint64_t early_stops() const { return early_stops_; }

 private:
  // Per block: its tree's arrays live in slot `slot` of the flat arrays below (n_ entries
  // each), handed out at the block's first search after clear().
  struct Tree {
    bool valid = false;
    std::int32_t slot = -1;
    std::uint64_t holders_version = 0;
    NodeId node = kNone;  // scene_local_: the node the roots were restricted to
  };
  Tree& tree(BlockId b, MemId m);
  bool tree_valid(BlockId b, MemId m);  // a cached tree answers for (b, m)
  NodeId restrict_node_ = kNone;  // with scene_local_: the destination's node
  // Dijkstra from b's holders, stopped once `stop` is settled (the rest of the tree is
  // marked unsettled: a later question about it searches again).
  void search(BlockId b, Tree& t, MemId stop);
  static constexpr std::size_t kEarlyStopAfter = 64;  // settled devices between search()'s early-stop checks
  static constexpr std::uint64_t kUnsettled = ~std::uint64_t{0};
  std::uint64_t path_stamp(const Tree& t, MemId m) const;
  std::uint64_t channel_stamp(ChannelId c) const {
    std::uint64_t v = 0;
    for (ResourceId r : schedule_->graph().channels[static_cast<std::size_t>(c)].resources) v += schedule_->resource_version(r);
    return v;
  }
  Time* arrival_of(const Tree& t) { return arrival_.data() + static_cast<std::size_t>(t.slot) * n_; }
  ChannelId* via_of(const Tree& t) { return via_.data() + static_cast<std::size_t>(t.slot) * n_; }
  const ChannelId* via_of(const Tree& t) const { return via_.data() + static_cast<std::size_t>(t.slot) * n_; }
  std::uint64_t* stamp_of(const Tree& t) { return stamp_.data() + static_cast<std::size_t>(t.slot) * n_; }

  const Schedule* schedule_;
  std::size_t n_ = 0;  // memory devices
  // Per source p, its channels p -> q with what Eq. 1 and admissibility need, contiguous
  // (the searches scan them for every label they expand): q's capacity, and the largest
  // capacity among q's other neighbours (q leads anywhere but back to p only for blocks no
  // larger than that).
  struct Hop {
    ChannelId channel;
    MemId to;
    Bytes to_capacity;
    Bytes onward_capacity;
    Time latency;
    double bandwidth;
    std::int32_t run = -1;  // out_hops(): at the first hop of a network run, its index in runs_
    Time transfer(double w) const { return latency + w / bandwidth; }  // Eq. 1, as DeviceGraph::transfer_time()
  };
  // A network's channels out of one member p, consecutive in p's hops (one per other
  // member): cut_search() decides about them together (NetworkFloor, fetch_bound.hpp).
  struct Run {
    std::uint32_t length;
    std::int32_t network, group;  // the members' group (FetchBound::group_of)
    FetchBound::Span span;        // its channels (shared resources: p's NIC-out, ...)
  };
  static constexpr std::uint32_t kMinRun = 4;  // shorter runs are expanded hop by hop
  std::vector<Run> runs_;
  bool runs_built_ = false;  // for rest_ and this graph (rebind() builds the hops again)
  std::vector<Time> group_max_;  // search(): per group, no member's label above it (kNever: unknown)
  std::vector<Hop> hops_;
  std::vector<std::uint32_t> hops_at_;  // p's hops: hops_[hops_at_[p], hops_at_[p + 1])
  void build_hops();
  void build_runs();
  std::span<const Hop> out_hops(MemId p) const {
    const auto pi = static_cast<std::size_t>(p);
    return {hops_.data() + hops_at_[pi], hops_.data() + hops_at_[pi + 1]};
  }
  std::vector<Tree> trees_;            // per block
  std::vector<BlockId> valid_trees_;   // the blocks whose tree is valid (what clear() resets)
  std::vector<BlockId> tree_slotted_;  // the blocks given a slot since clear() (which takes them back)
  std::vector<Time> arrival_;          // slot x memory device
  std::vector<ChannelId> via_;         // incoming tree channel (kNone at roots)
  std::vector<std::uint64_t> stamp_;   // sum of resource versions on the tree path
  std::int32_t slots_ = 0;
  std::vector<std::pair<Time, MemId>> heap_;
  std::vector<char> done_, holder_;
  // arrival_within(): labels, incoming channels, open labels, memo.
  std::vector<Time> label_;
  std::vector<ChannelId> label_via_;
  struct Open {
    Time bound, label;
    MemId mem;
  };
  struct OpenAfter {  // min-heap on the bound
    bool operator()(const Open& a, const Open& c) const { return a.bound > c.bound; }
  };
  std::vector<Open> open_;
  struct Memo {
    MemId m = kNone;
    std::uint64_t holders = 0;   // holders_version(b) when taken
    Time lb = -kNever;           // at most the arrival; the arrival itself while `path` is valid
    std::uint64_t stamp = 0;     // sum of the resource versions along `path` when taken
    std::int16_t hops = -1;      // `path` holds a best path of `hops` channels (-1: none)
    // No other admissible path ties with `path`. It stays so while `path` is valid, and
    // while `path` evaluates to `lb` again after bookings on it (arrival_within's re-stamp):
    // other paths only get slower. Once a lower bound raises `lb` past the value it was
    // proved at, a re-stamped `path` may have been delayed as much as another (a booking on
    // a resource both share), so raise_lb() drops the claim.
    bool unique = false;
    ChannelId path[kMemoHops] = {};
    void raise_lb(Time x) {
      if (x > lb) {
        lb = x;
        unique = false;
      }
    }
  };
  const FetchBound* rest_ = nullptr;
  std::vector<char> tie_;  // cut_search(): another admissible path reaches q with its label
  // Memory devices whose label_, label_via_, holder_ or tie_ entry may differ from the reset
  // state (kNever, kNone, 0, 0): a search resets only what the last one touched (its setup
  // is O(touched), not O(memory devices); most searches touch a handful).
  std::vector<MemId> touched_;
  void reset_labels() {
    for (const MemId q : touched_) {
      const auto qi = static_cast<std::size_t>(q);
      label_[qi] = kNever;
      label_via_[qi] = kNone;
      holder_[qi] = 0;
      tie_[qi] = 0;
    }
    touched_.clear();
  }
  bool cut_unique_ = false;  // cut_search()'s result came with a proof that its path is the only best one
  // cut_search() of a block with many initial copies ready together (a scene block on
  // every disk, Schedule::initial_prefix): those roots enter the search lazily, nearest to
  // the destination first. Per destination, the kNearRoots nearest (by the uncontended
  // T_TRANS bound of through()) and the least such bound of the others; a marker in the
  // open heap, keyed by the next root's floor, seeds it when popped, and the others all at
  // once after the near ones. A root's floor is at most its through() key, so no root
  // enters later than it would be expanded, and the search's labels are the same.
  static constexpr std::size_t kNearRoots = 6, kMinLazyRoots = 12;
  struct NearRoots {
    bool built = false;
    std::uint8_t n = 0;
    std::int32_t k[kNearRoots] = {};  // indices into copies(b), nearest first
    double rest = kNever;             // least distance of the prefix copies not listed
  };
  struct PrefixRoots {
    std::uint64_t stamp = 0;
    double bytes = -1;
    std::vector<NearRoots> near;  // per destination
  };
  std::unordered_map<BlockId, PrefixRoots> prefix_roots_;
  const NearRoots& near_roots(BlockId b, MemId m, const Schedule::CopyPrefix& pre, double w);
  // Branch and bound for b's arrival at m (arrival_within()). Ties: also explores paths
  // that tie with the best (for path()) and flags nodes reached by two of them.
  template <class Lost, bool Ties, bool Funnel = true>
  // (direct_checked: the caller found direct_before_relays() open for (b, m) already.)
  Time cut_search(BlockId b, MemId m, Time enough, const Lost& lost, Time& dropped, bool direct_checked = false);
  int via_hops(MemId m, MemId* root) const;  // cut_search's path to m (kMemoHops + 1: longer)
  // arrival_within() past its single-holder answer (`single`: that was asked, and left open).
  template <class Lost>
  Time arrival_within_open(BlockId b, MemId m, Time enough, const Lost& lost, Time* proven, int* hops, bool single);
  // A block on one memory device h != m (a ray queue) with one channel h -> m: when that
  // hop lands no later than any relayed last hop can (cut_search()'s first shortcut), or
  // than any relayed path's first hop out of h followed by the uncontended rest to m, its
  // Eq. 3 value is the SDC arrival, found without a memo or a search. With `funnel`, also a
  // destination behind one channel p -> m whose source p is answered so. NaN otherwise.
  // `route` (if given) gets the channels of that path: one, or two through p.
  // `tried` (if given) is set when b has one holder h != m and may enter m: then, open, it is
  // not a direct hop before every relayed one either (direct_before_relays()).
  Time single_holder_direct(BlockId b, MemId m, bool funnel = true, ChannelId* route = nullptr, bool* tried = nullptr) const;
  // For b not on m: the best direct hop from a holder into m when it lands no later than any
  // relayed last hop can (every path ends with one or the other), with its channel, and
  // whether it is the only best path (strictly first, no other direct hop as early). The
  // same operations as cut_search()'s first shortcut. NaN otherwise.
  Time direct_before_relays(BlockId b, MemId m, ChannelId& via, bool& unique) const;
  // The earliest a relayed last hop can land on m (rest_ set) for a block of `bytes`: from a
  // device that is no holder (nothing is routed through a holder) and can take it.
  // (stop_below: may return any value below it once the minimum is known to be.)
  template <class IsHolder>
  Time relay_end_in(MemId m, Bytes bytes, const IsHolder& is_holder, Time stop_below = -kNever) const {
    return rest_->relay_min(*schedule_, m, static_cast<double>(bytes), kNever, stop_below,
                            [&](const FetchBound::Relay& r) { return r.from_capacity >= bytes && !is_holder(r.from); });
  }
  // Memo lookup in O(1): per block asked about this pass, a slot of n_ indices into
  // memos_ (-1: none yet), one per memory device.
  std::vector<std::int32_t> memo_slot_;   // per block (-1: no slot this pass)
  std::vector<std::int32_t> memo_index_;  // slot x memory device
  std::vector<BlockId> slotted_;          // the blocks with a slot this pass
  std::vector<Memo> memos_;
  Memo& memo(BlockId b, MemId m);
  std::uint64_t memo_stamp(const Memo& e) const;  // resource versions along e.path now
  bool memo_exact(const Memo& e) const;
  // Eq. 3 along the memo's path as the Schedule stands now (e.hops > 0).
  Time memo_path_now(const Memo& e, BlockId b) const;
  std::uint64_t searches_ = 0, hits_ = 0, cut_searches_ = 0, early_stops_ = 0;
  std::size_t early_stop_ = kEarlyStopAfter;
  Time now_ = 0;
  bool scene_local_ = false;

  struct HeapAfter {  // min-heap on the label only (as it always was: ties keep heap order)
    bool operator()(const std::pair<Time, MemId>& a, const std::pair<Time, MemId>& c) const { return a.first > c.first; }
  };
  static constexpr HeapAfter heap_after{};
};

template <class Lost>
Time FetchPathFinder::arrival_within_open(BlockId b, MemId m, Time enough, const Lost& lost, Time* proven, int* hops,
                                          bool single) {
  auto answer = [&](Time a) {
    if (a <= enough || !lost(a)) return a;
    if (proven) *proven = a;
    return kNever;
  };
  if (restricted(b)) {  // roots depend on the destination's node: the plain way
    if (hops) {
      std::vector<ChannelId> p;
      path(b, m, p);
      *hops = static_cast<int>(p.size());
    }
    return answer(arrival(b, m));
  }
  Memo& f = memo(b, m);  // (cut_search() leaves memos_ alone: the reference stays valid)
  const std::uint64_t stamp_now = f.hops > 0 ? memo_stamp(f) : 0;
  if (f.hops >= 0 && stamp_now == f.stamp) {
    ++hits_;
    if (hops) *hops = f.hops;
    return answer(f.lb);
  }
  if (f.lb > enough && lost(f.lb)) {
    ++hits_;
    if (proven) *proven = f.lb;
    return kNever;
  }
  // A booking on the memoised path often does not delay it (a busier hop the data reaches
  // only after it is free again). Within a pass every path only gets slower, so when the
  // path still evaluates to (at most) the proven lower bound it is a best path again, and
  // the only one if it was: re-stamp it instead of searching. Otherwise its value is an
  // upper bound, which may already answer "by `enough`".
  if (f.hops > 0) {
    const Time v = memo_path_now(f, b);
    if (v <= f.lb) {
      ++hits_;
      f.lb = v;
      f.stamp = stamp_now;
      if (hops) *hops = f.hops;
      return answer(v);
    }
    if (v <= enough) {
      ++hits_;
      return v;
    }
  }
  // Before any search: the last hop's floor (FetchBound::last_hop_floor) often loses
  // already; it is a lower bound on the arrival, memoised as one.
  if (rest_ && !schedule_->copy_at(b, m)) {
    const Time floor = rest_->last_hop_floor(*schedule_, b, m);
    if (floor > enough && lost(floor)) {
      ++hits_;
      f.raise_lb(floor);
      if (proven) *proven = floor;
      return kNever;
    }
  }
  // The best direct hop from a holder, when no relayed last hop can land earlier: the
  // arrival without a search (cut_search()'s first shortcut, the same operations).
  if (!single) {
    ChannelId via = kNone;
    bool unique = false;
    if (const Time a = direct_before_relays(b, m, via, unique); a == a) {
      ++hits_;
      if (a > enough && lost(a)) {
        f.raise_lb(a);
        if (proven) *proven = a;
        return kNever;
      }
      f.lb = a;
      f.unique = unique;
      f.path[0] = via;
      f.stamp = channel_stamp(via);
      f.hops = 1;
      if (hops) *hops = 1;
      return a;
    }
  }
  ++cut_searches_;
  Time dropped = kNever;
  const Time a = cut_search<Lost, false>(b, m, enough, lost, dropped, true);
  if (a < kNever && label_[static_cast<std::size_t>(m)] == a) {
    // Exact: memoise it with its path (labels only improve, so the path through the
    // recorded channels evaluates to exactly this label).
    f.lb = a;  // (lb <= a before)
    MemId root = kNone;
    const int h = via_hops(m, &root);
    f.hops = -1;
    f.unique = cut_unique_;
    if (h <= kMemoHops && root != kNone) {
      MemId q = m;
      f.stamp = 0;
      for (int k = h - 1; k >= 0; --k) {
        const ChannelId c = label_via_[static_cast<std::size_t>(q)];
        f.path[k] = c;
        f.stamp += channel_stamp(c);
        q = schedule_->graph().channels[static_cast<std::size_t>(c)].from;
      }
      f.hops = static_cast<std::int16_t>(h);
    }
    if (hops) *hops = h;
    return a;
  }
  if (a < kNever) return a;  // <= enough, not exact
  f.raise_lb(dropped);
  if (proven) *proven = dropped;
  return kNever;
}

// Branch and bound over the same Eq. 3 labels as search(): a label l at q is expanded in
// order of through(l, q), a lower bound on m's label along any path continuing from it
// (l itself without bounds), and re-expanded if it improves. Once the least open bound
// reaches m's best label, that label is the minimum over all admissible paths, i.e.
// search()'s arrival (the same floating-point chain, along a best path). Returns m's
// label (== label_[m]), or a label <= enough found on the way (!= label_[m]), or kNever
// (then `dropped` bounds the arrival from below).
template <class Lost, bool Ties, bool Funnel>
Time FetchPathFinder::cut_search(BlockId b, MemId m, Time enough, const Lost& lost, Time& dropped, bool direct_checked) {
  const DeviceGraph& g = schedule_->graph();
  const DataBlock& blk = schedule_->pool().block(b);
  const auto mi = static_cast<std::size_t>(m);
  cut_unique_ = false;
  reset_labels();
  open_.clear();
  const auto bytes = blk.bytes;
  const double wbytes = static_cast<double>(bytes);
  const FetchBound* rest = rest_;
  const double* rest_lat = rest ? rest->latency_to(m) : nullptr;
  const double* rest_inv_bw = rest ? rest->inv_bw_to(m) : nullptr;
  const ChannelId* direct = rest ? rest->direct_to(m) : nullptr;
  const std::vector<Copy>& copies = schedule_->copies(b);
  // Lazy roots (see NearRoots): copies [0, lazy) enter the search nearest first; they are
  // holders from the start (pos), marked in holder_ once seeded.
  const Schedule::CopyPrefix pre = rest ? schedule_->initial_prefix(b) : Schedule::CopyPrefix{};
  const std::size_t lazy = pre.count >= kMinLazyRoots ? pre.count : 0;
  const std::int32_t* pos = lazy ? schedule_->copy_positions(b) : nullptr;
  for (std::size_t k = lazy; k < copies.size(); ++k) {
    holder_[static_cast<std::size_t>(copies[k].mem)] = 1;
    touched_.push_back(copies[k].mem);
  }
  auto is_holder = [&](std::size_t qi) { return holder_[qi] != 0 || (pos && pos[qi] >= 0); };
  if (!is_holder(mi) && g.memories[mi].capacity < bytes) return kNever;  // never routed into m
  // A destination reached by one channel only (a GPU behind its host memory): its arrival
  // is Eq. 3 on that hop after the arrival at the channel's source (every path to m ends
  // with it), and its best paths are those to the source, extended.
  if constexpr (Funnel) if (rest && !is_holder(mi) && blk.movable && g.in_channels(m).size() == 1) {
    const ChannelId c = g.in_channels(m)[0];
    const MemId p = g.channels[static_cast<std::size_t>(c)].from;
    if (!is_holder(static_cast<std::size_t>(p)) && g.memories[static_cast<std::size_t>(p)].capacity >= bytes) {
      const Time finish = schedule_->channel_finish(c), trans = g.transfer_time(c, bytes);
      auto hop = [&](Time x) { return std::max(x, finish) + trans; };  // Eq. 3
      auto lost_at_p = [&](Time x) { return lost(hop(x)); };
      Time dropped_at_p = kNever;
      const Time ap = cut_search<decltype(lost_at_p), Ties, false>(b, p, -kNever, lost_at_p, dropped_at_p);
      if (ap == kNever) {
        if (dropped_at_p < kNever) dropped = std::min(dropped, hop(dropped_at_p));
        return kNever;
      }
      const Time am = hop(ap);
      label_[mi] = am;
      label_via_[mi] = c;
      touched_.push_back(m);
      if constexpr (Ties) tie_[mi] = 0;
      return am;
    }
  }
  // Every path to m is one direct hop from a holder or ends with a relayed hop. When the
  // best direct hop lands no later than any relayed one can, it is the arrival (Ties: and
  // when it lands strictly first and no other direct hop ties, the only best path).
  if (rest && !is_holder(mi) && blk.movable && !direct_checked) {
    ChannelId via = kNone;
    bool unique = false;
    if (const Time best = direct_before_relays(b, m, via, unique); best == best && (!Ties || unique)) {
      if (best > enough && lost(best)) {
        dropped = std::min(dropped, best);
        return kNever;
      }
      label_[mi] = best;
      label_via_[mi] = via;
      touched_.push_back(m);
      cut_unique_ = unique;
      return best;
    }
  }
  const Time relay_end = rest ? relay_end_in(m, bytes, [&](MemId q) { return is_holder(static_cast<std::size_t>(q)); }) : kNever;
  // A lower bound on m's label along any path on from label l at q: the uncontended rest
  // (scaled below the real-arithmetic sum by far more than the rounding of any Eq. 3
  // chain), and the last hop: q's own channel into m or a relayed one (Eq. 3 as is).
  auto through = [&](Time l, MemId q) -> Time {
    if (!rest || q == m) return l;
    const auto qi = static_cast<std::size_t>(q);
    const Time free_run = FetchBound::free_run_floor(l, rest_lat[qi] + wbytes * rest_inv_bw[qi]);
    Time last = relay_end;
    if (const ChannelId c = direct[qi]; c >= 0) {
      last = std::min(last, std::max(l, schedule_->channel_finish(c)) + g.transfer_time(c, bytes));
    } else if (c == FetchBound::kSeveral) {
      for (ChannelId d : g.out_channels(q))
        if (g.channels[static_cast<std::size_t>(d)].to == m)
          last = std::min(last, std::max(l, schedule_->channel_finish(d)) + g.transfer_time(d, bytes));
    }
    return std::max(free_run, last);
  };
  auto seed = [&](const Copy& c) {
    const auto qi = static_cast<std::size_t>(c.mem);
    if (lazy && !holder_[qi]) {
      holder_[qi] = 1;
      touched_.push_back(c.mem);
    }
    const Time r = std::max(now_, schedule_->copy_ready(c));
    if (r < label_[qi]) {
      const Time x = through(r, c.mem);
      if (x > enough && lost(x)) {
        dropped = std::min(dropped, x);
        return;
      }
      label_[qi] = r;
      touched_.push_back(c.mem);
      open_.push_back({x, r, c.mem});
      std::push_heap(open_.begin(), open_.end(), OpenAfter{});
    }
  };
  for (std::size_t k = lazy; k < copies.size(); ++k) seed(copies[k]);
  // The lazy roots: m's own copy at once (a holder's label is final), then a marker.
  const NearRoots* near = nullptr;
  std::size_t next_near = 0;
  bool rest_seeded = false;
  const Time lazy_ready = lazy ? std::max(now_, schedule_->copy_ready(copies[0])) : 0;
  auto push_marker = [&] {
    double dist = kNever;
    if (next_near < near->n) {
      const auto qi = static_cast<std::size_t>(copies[static_cast<std::size_t>(near->k[next_near])].mem);
      dist = rest_lat[qi] + wbytes * rest_inv_bw[qi];
    } else if (!rest_seeded) {
      dist = near->rest;
    }
    if (!(dist < kNever)) return;
    const Time floor = FetchBound::free_run_floor(lazy_ready, dist);  // through()'s free run
    if (floor > enough && lost(floor)) {  // every root left has through() >= floor
      dropped = std::min(dropped, floor);
      return;
    }
    open_.push_back({floor, kNever, kNone});
    std::push_heap(open_.begin(), open_.end(), OpenAfter{});
  };
  if (lazy) {
    if (pos[mi] >= 0 && static_cast<std::size_t>(pos[mi]) < lazy) seed(copies[static_cast<std::size_t>(pos[mi])]);
    near = &near_roots(b, m, pre, wbytes);
    push_marker();
  }
  if (is_holder(mi) || !blk.movable) return label_[mi];  // a holder's label is final
  while (!open_.empty()) {
    const Open top = open_.front();
    // Nothing open can beat m's label (Ties: nor reach it).
    if (Ties ? top.bound > label_[mi] : top.bound >= label_[mi]) break;
    std::pop_heap(open_.begin(), open_.end(), OpenAfter{});
    open_.pop_back();
    if (top.mem == kNone) {  // the lazy roots' marker: the next near root, or all the others
      if (next_near < near->n) {
        seed(copies[static_cast<std::size_t>(near->k[next_near++])]);
      } else {
        rest_seeded = true;
        for (std::size_t k = 0; k < lazy; ++k) {
          const MemId q = copies[k].mem;
          if (q == m || std::find(near->k, near->k + near->n, static_cast<std::int32_t>(k)) != near->k + near->n) continue;
          seed(copies[k]);
        }
      }
      push_marker();
      continue;
    }
    if (top.label != label_[static_cast<std::size_t>(top.mem)]) continue;  // superseded
    // Relaxes one hop out of top (Eq. 3). Returns m's label when the hop reaches m by
    // `enough` (the search ends), NaN otherwise.
    constexpr Time kGoOn = std::numeric_limits<Time>::quiet_NaN();
    auto relax = [&](const Hop& hop) -> Time {
      const MemId q = hop.to;
      const ChannelId c = hop.channel;
      const auto qi = static_cast<std::size_t>(q);
      if (is_holder(qi) || hop.to_capacity < bytes) return kGoOn;
      const Time lq = std::max(top.label, schedule_->channel_finish(c)) + hop.transfer(wbytes);  // Eq. 3
      if (!(lq < label_[qi])) {
        if constexpr (Ties)
          if (lq == label_[qi] && c != label_via_[qi]) tie_[qi] = 1;
        return kGoOn;
      }
      if (q == m && lq <= enough) return lq;  // a <= lq <= enough
      const Time x = through(lq, q);
      if (x > enough && lost(x)) {
        dropped = std::min(dropped, x);
        return kGoOn;
      }
      label_[qi] = lq;
      label_via_[qi] = c;
      touched_.push_back(q);
      if constexpr (Ties) tie_[qi] = 0;
      if (q != m) {
        open_.push_back({x, lq, q});
        std::push_heap(open_.begin(), open_.end(), OpenAfter{});
      }
      return kGoOn;
    };
    const std::span<const Hop> hs = out_hops(top.mem);
    for (std::size_t h = 0; h < hs.size(); ++h) {
      if (rest && hs[h].run >= 0) {
        // A network run: its hop into m (if any) first, then the others together. Every
        // other member q gets through(l_q, q) >= the run's floor (fetch_bound.hpp,
        // NetworkFloor), so when the floor cannot beat m's label no hop of the run would be
        // expanded (Ties: nor tie with it), and when it loses, none would be kept: skip
        // them. Otherwise expand the run hop by hop (the hop into m again: a no-op).
        const Run& run = runs_[static_cast<std::size_t>(hs[h].run)];
        const ChannelId into_m = direct[static_cast<std::size_t>(top.mem)];
        if (into_m >= 0 && g.channels[static_cast<std::size_t>(into_m)].network == run.network) {
          const Channel& ch = g.channels[static_cast<std::size_t>(into_m)];
          const Hop hm{into_m, m, g.memories[mi].capacity, 0, ch.latency, ch.bandwidth};
          if (const Time a = relax(hm); a == a) return a;
        }
        if (into_m >= 0 || into_m == kNone) {
          const Time floor = rest->network_floor(*schedule_, m, run.group, run.span.earliest_end(*schedule_, top.label, wbytes),
                                                 wbytes, relay_end);
          const bool skip = Ties ? floor > label_[mi] : floor >= label_[mi];
          if (skip || (floor > enough && lost(floor))) {
            if (!skip) dropped = std::min(dropped, floor);
            h += run.length - 1;
            continue;
          }
        }
      }
      if (const Time a = relax(hs[h]); a == a) return a;
    }
  }
  return label_[mi];
}

}  // namespace rayline

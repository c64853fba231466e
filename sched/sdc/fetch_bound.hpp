// A cheap lower bound on SDC arrival times, for pruning GMB's job selection. With no
// contention a fetch over path P costs sum(lat) + |w| * sum(1/bw) (Eq. 1 summed over hops,
// Fig. 4's chaining). Contention only delays, and for any path
//     sum(lat) + |w| sum(1/bw) >= L(h, m) + |w| W(h, m),
// where L and W are the all-pairs minima of total latency and of total inverse bandwidth
// (computed separately, so the bound holds whatever path SDC finally picks). Hence
//     arrival(b, m) >= min over holders h of max(now, ready_h) + L(h, m) + |b| W(h, m).
// Tighter, through the last hop (which must be one of m's incoming channels c = p -> m,
// and cannot start before c is free, Eq. 3):
//     arrival(b, m) >= min over c of max(LB(b, p), FinishTime(c)) + T_TRANS(c, |b|).
//
// Both bounds are memoised (planning speed): the holders term per (block, memory
// device) until the block's holders change, the last-hop bound per (block, memory device)
// until the holders or a resource of one of m's incoming channels change (the Schedule's
// versions), so a commit re-opens only the bounds it can move. Values are bit-identical to
// recomputing them.
#pragma once
#include <algorithm>
#include <unordered_map>
#include <vector>

#include "sched/timeline/schedule.hpp"

namespace rayline {

class FetchBound {
 public:
  explicit FetchBound(const DeviceGraph& g);
  // Forget every memoised bound (call after reproject(): activities moved). O(1).
  // A new planning pass: every memo is stale (they are per pass), so the slots are given
  // out again from the start, keeping the memory a long run would otherwise grow.
  void reset() {
    ++epoch_;
    for (BlockId b : slotted_) slot_of_block_[static_cast<std::size_t>(b)] = -1;
    slotted_.clear();
    memos_.clear();
  }
  Time lower_bound(const Schedule& s, BlockId b, MemId m, Time now) const;
  // The same value, not memoised (for blocks asked about once, e.g. a job's ray queue).
  Time lower_bound_once(const Schedule& s, BlockId b, MemId m, Time now) const;
  // The uncontended part alone: min over holders of max(now, ready) + L + |b| W (memoised
  // while b's holders are unchanged).
  Time free_run_bound(const Schedule& s, BlockId b, MemId m, Time now) const { return holders_bound(s, b, m, now); }
  // An upper bound: the best path of one or two hops from a holder into m, with Eq. 3 on
  // that path (the second hop chained after the first); SDC's arrival is never later.
  // kNever when no holder is within two hops.
  Time direct_upper_bound(const Schedule& s, BlockId b, MemId m, Time now) const;
  // For FetchPathFinder::arrival_within(), per destination m:
  //  * per memory device q: the least total latency / total inverse bandwidth of any path
  //    q -> m (uncontended; +inf where none);
  //  * the channels into m that a simple path from a non-adjacent device can end with
  //    (their source has an incoming channel from a device other than m): a last hop from
  //    p != q into m is one of them;
  //  * the channel q -> m (kNone: none; kSeveral: more than one).
  static constexpr ChannelId kSeveral = -2;
  // A lower bound on the SDC arrival of b at m, b not on m, from the last hop alone. A
  // simple path from a holder ends with a channel c = p -> m that is a relay channel
  // (relay_in(m): p is reached from a device other than m) or leaves a holder, and by
  // Eq. 3 it ends at max(l_p, FinishTime(c)) + T_TRANS(c, |b|) >= FinishTime(c) +
  // T_TRANS(c, |b|) (rounding is monotone). The minimum of that over those channels; not
  // memoised (it moves with every booking of them), O(in-degree of m), no search.
  Time last_hop_floor(const Schedule& s, BlockId b, MemId m) const;
  const double* latency_to(MemId m) const { return lat_to_.data() + static_cast<std::size_t>(m) * n_; }
  const double* inv_bw_to(MemId m) const { return inv_bw_to_.data() + static_cast<std::size_t>(m) * n_; }
  //    Each with what Eq. 1 and the capacity check need, stored contiguously (the search
  //    scans them for every destination it is asked about).
  struct Relay {
    ChannelId channel;
    MemId from;
    Bytes from_capacity;
    Time latency;      // T_LAT
    double bandwidth;  // T_BW
    // When data ready at FinishTime(c) = `finish` lands through this hop: finish +
    // T_TRANS(c, |w|) (Eq. 3, Eq. 1 as transfer_time()), or kNever when it cannot land
    // before `before`: FinishTime + T_LAT alone does not beat it, and |w|/T_BW >= 0 with
    // monotone rounding, so Eq. 1's division is skipped (a minimum over hops is unchanged).
    Time lands_before(Time finish, double w, Time before) const {
      if (!(finish + latency < before)) return kNever;
      return finish + (latency + w / bandwidth);
    }
  };
  const std::vector<Relay>& relay_in(MemId m) const { return relay_in_[static_cast<std::size_t>(m)]; }
  // The least Relay::lands_before(FinishTime(c), w, ·) over m's relays `admit` takes, and
  // `end`, whichever is less; returns as soon as it is below `stop_below`. The relays
  // come in runs (one group's members over one network, NetworkFloor below): a run whose
  // floor, max(busy(its common resources)) + lat_min + |w| / bw_max, is no less than the
  // minimum so far cannot lower it and is skipped whole (the same minimum).
  template <class Admit>
  Time relay_min(const Schedule& s, MemId m, double w, Time end, Time stop_below, const Admit& admit) const {
    const std::vector<Relay>& rs = relay_in_[static_cast<std::size_t>(m)];
    for (const RelayRun& run : relay_runs_[static_cast<std::size_t>(m)]) {
      if (run.end - run.begin >= kMinRelayRun && !(run.span.earliest_end(s, 0, w) < end))
        continue;
      for (std::uint32_t i = run.begin; i < run.end; ++i) {
        const Relay& r = rs[i];
        if (!admit(r)) continue;
        if (const Time t = r.lands_before(s.channel_finish(r.channel), w, end); t < end) {
          end = t;
          if (end < stop_below) return end;
        }
      }
    }
    return end;
  }
  const ChannelId* direct_to(MemId m) const { return direct_to_.data() + static_cast<std::size_t>(m) * n_; }
  // NetworkFloor. A network's members fall into groups (its racks; all of them without
  // racks). The search meets a network's channels out of one member p to one group's
  // members as a run: with l the label at p, every channel c = p -> q of the run lands at
  //     l_q = max(l, FinishTime(c)) + T_TRANS(c, |w|) >= L = max(l, busy(R)) + lat_min + |w| / bw_max
  // where FinishTime(c) is the latest busy-until of c's resources, R the resources every
  // channel of the run uses (p's NIC-out; between racks also the uplink and backbone), and
  // lat_min, bw_max over the run. The search's bound through q != m is the larger of
  //  * the uncontended rest: (l_q + (L(q, m) + |w| W(q, m)) (1 - 1e-9)) (1 - 1e-14), with
  //    L and W no smaller than their minima over the group's members other than m;
  //  * the last hop: the least relayed one (`relay_end`) or a channel from q into m,
  //    which lands no earlier than max(L, busy(R_in)) + lat + |w| / bw, R_in the resources
  //    every channel from the group into m uses, lat and bw the least and largest of them.
  // The same operations as the search's bound, each monotone, so the value is a floor of
  // every member's bound, in floating point too. And when m's node is in another group H
  // (a rack of the same network) that shares no node with this one, a cut: every path from
  // the run's members to m leaves the group's nodes by some channel and enters H's by a
  // last such channel, which starts after l_q, the resources every leaving channel uses
  // and those every entering channel uses are free:
  //     arrival >= max(L, busy(R_leave), busy(R_enter)) + least T_TRANS of an entering channel.
  // Not a floor of the search's bound, but of every arrival through the run: what a
  // skipped run could give m is no better than m's label.
  static constexpr int kCommon = 4;  // resources kept of a common set (a subset: a smaller floor)
  struct Common {
    ResourceId r[kCommon] = {kNone, kNone, kNone, kNone};
    Time busy(const Schedule& s) const {
      Time t = 0;
      for (ResourceId x : r)
        if (x != kNone) t = std::max(t, s.resource_timeline(x).busy_until);
      return t;
    }
  };
  // Resources on every one of these channels (at most kCommon of them).
  static Common common_resources(const DeviceGraph& g, const std::vector<ChannelId>& channels);
  // A set of channels taken together (a run): when data ready at l crosses any of them,
  // Eq. 3 lands it no earlier than max(l, busy(common)) + lat_min + |w| / bw_max.
  struct Span {
    Common common;
    Time min_latency = kNever;
    double max_bandwidth = 0;
    static Span of(const DeviceGraph& g, const std::vector<ChannelId>& channels);
    Time earliest_end(const Schedule& s, Time l, double w) const {
      return std::max(l, common.busy(s)) + (min_latency + w / max_bandwidth);
    }
  };
  std::size_t group_count() const { return groups_; }
  std::int32_t group_of(std::int32_t k, MemId q) const {
    return group_of_[static_cast<std::size_t>(k) * n_ + static_cast<std::size_t>(q)];
  }
  // A label l followed by an uncontended rest of `rest` seconds (latency + |w|/bandwidth
  // minima), scaled below the real-arithmetic sum by far more than the rounding of any
  // Eq. 3 chain: the floor every search and bound here compares against.
  static Time free_run_floor(Time l, double rest) { return (l + rest * (1 - 1e-9)) * (1 - 1e-14); }
  // With lq = the run's Span::earliest_end (a floor of every l_q): the first part alone,
  // a floor of the uncontended rest's bound over the run's members ...
  Time network_free_run(MemId m, std::int32_t group, Time lq, double w) const {
    const NetworkRest& r = network_rest_[static_cast<std::size_t>(m) * groups_ + static_cast<std::size_t>(group)];
    return free_run_floor(lq, r.latency + w * r.inv_bw);
  }
  // ... and NetworkFloor whole.
  Time network_floor(const Schedule& s, MemId m, std::int32_t group, Time lq, double w, Time relay_end) const {
    const NetworkRest& r = network_rest_[static_cast<std::size_t>(m) * groups_ + static_cast<std::size_t>(group)];
    const Time free_run = network_free_run(m, group, lq, w);
    const Time last = std::min(relay_end, std::max(lq, r.in.busy(s)) + (r.in_latency + w / r.in_bandwidth));
    Time floor = std::max(free_run, last);
    const Group& from = groups_info_[static_cast<std::size_t>(group)];
    const std::int32_t h = node_group_[static_cast<std::size_t>(from.network) * nodes_ + static_cast<std::size_t>(node_of_[static_cast<std::size_t>(m)])];
    if (h >= 0 && h != group && !overlap_[static_cast<std::size_t>(group) * groups_ + static_cast<std::size_t>(h)]) {
      const Group& to = groups_info_[static_cast<std::size_t>(h)];
      const Time cut = std::max({lq, from.leave.busy(s), to.enter.busy(s)}) + (to.enter_latency + w / to.enter_bandwidth);
      floor = std::max(floor, cut);
    }
    return floor;
  }

 private:
  Time holders_bound(const Schedule& s, BlockId b, MemId m, Time now) const {
    Memo& e = memo(b, m).holders;
    const std::uint64_t hv = s.holders_version(b);
    if (e.epoch == epoch_ && e.holders == hv) return e.value;
    return holders_bound_fill(s, b, m, now, e, hv);
  }
  Time holders_bound_uncached(const Schedule& s, BlockId b, MemId m, Time now) const;
  Time lower_bound_uncached(const Schedule& s, BlockId b, MemId m, Time now, bool memoised_holders,
                            ChannelId* arg = nullptr) const;
  std::uint64_t channel_stamp(const Schedule& s, ChannelId c) const;
  void all_pairs_minima(const DeviceGraph& g);

  std::size_t n_;
  std::vector<double> lat_, inv_bw_;  // n x n, +inf where unreachable
  std::vector<double> lat_to_, inv_bw_to_;  // the same, transposed (rows by destination)
  std::vector<std::vector<Relay>> relay_in_;
  struct RelayRun {
    std::uint32_t begin, end;  // in relay_in_[m]
    Span span;
  };
  static constexpr std::uint32_t kMinRelayRun = 4;
  std::vector<std::vector<RelayRun>> relay_runs_;  // per m: its relays, in order, in runs
  void build_relay_runs(const DeviceGraph& g);
  std::vector<ChannelId> direct_to_;  // [m * n + q]
  // Per destination m and group: the least L(q, m) and W(q, m) over the group's members
  // q != m; the channels into m from them: least latency, largest bandwidth, resources
  // they all use.
  struct NetworkRest {
    double latency = kNever, inv_bw = kNever;
    Time in_latency = kNever;
    double in_bandwidth = 1;
    Common in;
  };
  struct Group {
    std::int32_t network = -1;
    Common leave, enter;  // resources every channel leaving / entering the group's nodes uses
    Time enter_latency = kNever;
    double enter_bandwidth = 1;
  };
  std::vector<Group> groups_info_;
  std::vector<char> overlap_;            // [g * groups_ + h]: the groups share a node
  std::size_t nodes_ = 0;
  std::vector<NodeId> node_of_;          // per memory device
  std::vector<std::int32_t> node_group_; // [k * nodes_ + node]: the node's group in network k (-1: none)
  std::size_t groups_ = 0;
  std::vector<std::int32_t> group_of_;     // [k * n + q]: q's group in network k (-1: no member)
  std::vector<NetworkRest> network_rest_;  // [m * groups_ + group]
  void network_groups(const DeviceGraph& g);
  // Per destination m: its incoming channels that are no relay channel (their source is
  // reached only through m, e.g. m's GPU memory or disk), with what Eq. 1 needs.
  std::vector<std::vector<Relay>> own_in_;
  struct Memo {
    Time value = 0;
    std::uint64_t holders = 0;  // holders_version(b) when taken
    std::uint64_t in = 0;       // lower_bound: versions of the resources of `arg` when taken
    ChannelId arg = kNone;      // lower_bound: the last hop attaining it (kNone: b on m)
    std::uint64_t epoch = 0;    // reset() count when taken (0: never); reset() at every new `now`
  };
  struct Memos {
    Memo holders, lower;
  };
  std::uint64_t epoch_ = 1;
  // Per block that was asked about: one slot of n_ entries (most blocks never are).
  mutable std::vector<std::int32_t> slot_of_block_;
  mutable std::vector<Memos> memos_;
  mutable std::vector<BlockId> slotted_;  // the blocks with a slot this pass
  Memos& memo(BlockId b, MemId m) const {
    const auto bi = static_cast<std::size_t>(b);
    if (bi >= slot_of_block_.size() || slot_of_block_[bi] < 0) add_slot(b);
    return memos_[static_cast<std::size_t>(slot_of_block_[bi]) * n_ + static_cast<std::size_t>(m)];
  }
  void add_slot(BlockId b) const;
  // holders_bound_uncached(): per block with many initial copies, per destination their
  // least uncontended fetch time (NaN: not computed yet), for the prefix stamped `stamp`.
  struct PrefixFloor {
    std::uint64_t stamp = 0;
    double bytes = -1;          // the block's size it was computed for
    Time ready = 0;             // the prefix's earliest copy_ready()
    std::vector<double> least;  // per memory device
  };
  mutable std::unordered_map<BlockId, PrefixFloor> prefix_floors_;
  Time holders_bound_fill(const Schedule& s, BlockId b, MemId m, Time now, Memo& e, std::uint64_t hv) const;
};

}  // namespace rayline

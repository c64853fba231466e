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
#include <vector>

#include "sched/timeline/schedule.hpp"

namespace rayline {

class FetchBound {
 public:
  explicit FetchBound(const DeviceGraph& g);
  // Forget every memoised bound (call after reproject(): activities moved). O(1).
  void reset() { ++epoch_; }
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
  const ChannelId* direct_to(MemId m) const { return direct_to_.data() + static_cast<std::size_t>(m) * n_; }

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
  std::vector<ChannelId> direct_to_;  // [m * n + q]
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
  Memos& memo(BlockId b, MemId m) const {
    const auto bi = static_cast<std::size_t>(b);
    if (bi >= slot_of_block_.size() || slot_of_block_[bi] < 0) add_slot(b);
    return memos_[static_cast<std::size_t>(slot_of_block_[bi]) * n_ + static_cast<std::size_t>(m)];
  }
  void add_slot(BlockId b) const;
  Time holders_bound_fill(const Schedule& s, BlockId b, MemId m, Time now, Memo& e, std::uint64_t hv) const;
};

}  // namespace rayline

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
// Both bounds are memoised (issue 2, planning speed): the holders term per (block, memory
// device) until the block's holders change, the last-hop bound per (block, memory device)
// until the holders or a resource of one of m's incoming channels change (the Schedule's
// versions), so a commit re-opens only the bounds it can move. Values are bit-identical to
// recomputing them.
#pragma once
#include <vector>

#include "schedule.hpp"

namespace rayline {

class FetchBound {
 public:
  explicit FetchBound(const DeviceGraph& g);
  // Forget every memoised bound (call after reproject(): activities moved). O(1).
  void reset() { ++epoch_; }
  Time lower_bound(const Schedule& s, BlockId b, MemId m, Time now) const;
  // The same value, not memoised (for blocks asked about once, e.g. a job's ray queue).
  Time lower_bound_once(const Schedule& s, BlockId b, MemId m, Time now) const;
  // An upper bound: the best path of one or two hops from a holder into m, with Eq. 3 on
  // that path (the second hop chained after the first); SDC's arrival is never later.
  // kNever when no holder is within two hops.
  Time direct_upper_bound(const Schedule& s, BlockId b, MemId m, Time now) const;

 private:
  Time holders_bound(const Schedule& s, BlockId b, MemId m, Time now) const;
  Time holders_bound_uncached(const Schedule& s, BlockId b, MemId m, Time now) const;
  Time lower_bound_uncached(const Schedule& s, BlockId b, MemId m, Time now, bool memoised_holders) const;
  std::uint64_t in_stamp(const Schedule& s, MemId m) const;  // versions of m's incoming resources

  std::size_t n_;
  std::vector<double> lat_, inv_bw_;  // n x n, +inf where unreachable
  std::vector<std::vector<ResourceId>> in_resources_;  // per memory device, distinct
  struct Memo {
    Time value = 0;
    std::uint64_t holders = 0;  // holders_version(b) when taken
    std::uint64_t in = 0;       // in_stamp(m) when taken (lower_bound only)
    std::uint64_t epoch = 0;    // reset() count when taken (0: never); reset() at every new `now`
  };
  struct Memos {
    Memo holders, lower;
  };
  std::uint64_t epoch_ = 1;
  // Per block that was asked about: one slot of n_ entries (most blocks never are).
  mutable std::vector<std::int32_t> slot_of_block_;
  mutable std::vector<Memos> memos_;
  Memos& memo(BlockId b, MemId m) const;
};

}  // namespace rayline

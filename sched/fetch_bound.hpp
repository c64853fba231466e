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
#pragma once
#include <vector>

#include "schedule.hpp"

namespace rayline {

class FetchBound {
 public:
  explicit FetchBound(const DeviceGraph& g);
  Time lower_bound(const Schedule& s, BlockId b, MemId m, Time now) const;
  // An upper bound: the best path of one or two hops from a holder into m, with Eq. 3 on
  // that path (the second hop chained after the first); SDC's arrival is never later.
  // kNever when no holder is within two hops.
  Time direct_upper_bound(const Schedule& s, BlockId b, MemId m, Time now) const;

 private:
  Time holders_bound(const Schedule& s, BlockId b, MemId m, Time now) const;

 public:

 private:
  std::size_t n_;
  std::vector<double> lat_, inv_bw_;  // n x n, +inf where unreachable
};

}  // namespace rayline

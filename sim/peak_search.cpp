#include "sim/peak_search.hpp"

#include <algorithm>

namespace rayline::sim {

int next_peak_point(const std::vector<PeakPoint>& points, const PeakSearch& opt) {
  if (points.empty()) return 1;
  // A point that is not steady is a miss (its rate is not one that holds), never the best.
  double best = -1;
  int misses = 0;
  for (const PeakPoint& p : points) {
    if (!p.steady) {
      ++misses;
      continue;
    }
    if (best < 0 || p.rate > best * (1 + opt.gain)) {
      misses = 0;
    } else {
      ++misses;
    }
    best = std::max(best, p.rate);
  }
  if (misses >= 2) return 0;
  const int last = points.back().clients;
  if (last >= opt.max_clients) return 0;
  return std::min(last * 2, opt.max_clients);
}

PeakPoint peak_of(const std::vector<PeakPoint>& points) {
  PeakPoint best{0, 0, false};
  for (const PeakPoint& p : points) {
    const bool better = best.clients == 0 || (p.steady && !best.steady) || (p.steady == best.steady && p.rate > best.rate);
    if (better) best = p;
  }
  return best;
}

}  // namespace rayline::sim

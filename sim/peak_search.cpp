#include "sim/peak_search.hpp"

#include <algorithm>

namespace rayline::sim {

int next_peak_point(const std::vector<PeakPoint>& points, const PeakSearch& opt) {
  if (points.empty()) return 1;
  if (!points.back().steady) return 0;  // overloaded: more clients only fill queues
  double best = points.front().rate;
  int misses = 0;
  for (std::size_t i = 1; i < points.size(); ++i) {
    if (points[i].rate > best * (1 + opt.gain)) {
      misses = 0;
    } else {
      ++misses;
    }
    if (points[i].rate > best) best = points[i].rate;
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

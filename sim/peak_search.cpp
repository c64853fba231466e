#include "sim/peak_search.hpp"

#include <algorithm>

namespace rayline::sim {

int next_peak_point(const std::vector<std::pair<int, double>>& points, const PeakSearch& opt) {
  if (points.empty()) return 1;
  double best = points.front().second;
  int misses = 0;
  for (std::size_t i = 1; i < points.size(); ++i) {
    if (points[i].second > best * (1 + opt.gain)) {
      misses = 0;
    } else {
      ++misses;
    }
    if (points[i].second > best) best = points[i].second;
  }
  if (misses >= 2) return 0;
  const int last = points.back().first;
  if (last >= opt.max_clients) return 0;
  return std::min(last * 2, opt.max_clients);
}

std::pair<int, double> peak_of(const std::vector<std::pair<int, double>>& points) {
  std::pair<int, double> best{0, 0};
  for (const auto& p : points)
    if (best.first == 0 || p.second > best.second) best = p;
  return best;
}

}  // namespace rayline::sim

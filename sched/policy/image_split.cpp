#include "sched/policy/image_split.hpp"

namespace rayline {

std::vector<double> node_ray_throughput(const DeviceGraph& g) {
  const JobTypeId ri = g.job_type("RayIntersect");
  std::vector<double> w(g.nodes.size(), 0.0);
  if (ri == kNone) return w;
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const NodeId n = g.computes[d].node;
    if (n < 0 || static_cast<std::size_t>(n) >= w.size() || !g.timing.supports(static_cast<DeviceId>(d), ri)) continue;
    const double rate = g.timing.at(static_cast<DeviceId>(d), ri).rate[static_cast<std::size_t>(DataKind::RayQueue)];
    if (rate > 0) w[static_cast<std::size_t>(n)] += 1.0 / rate;
  }
  return w;
}

int weighted_pick(std::uint64_t key, const std::vector<double>& weights) {
  double total = 0;
  for (double x : weights) total += x > 0 ? x : 0;
  if (total <= 0) return kNone;
  // splitmix64's finaliser: neighbouring ids land far apart.
  std::uint64_t h = key + 0x9e3779b97f4a7c15ull;
  h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ull;
  h = (h ^ (h >> 27)) * 0x94d049bb133111ebull;
  h ^= h >> 31;
  const double u = static_cast<double>(h >> 11) * 0x1.0p-53 * total;
  double acc = 0;
  int last = kNone;
  for (std::size_t i = 0; i < weights.size(); ++i) {
    if (weights[i] <= 0) continue;
    acc += weights[i];
    last = static_cast<int>(i);
    if (u < acc) return last;
  }
  return last;
}

}  // namespace rayline

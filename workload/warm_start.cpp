#include "workload/warm_start.hpp"

#include "workload/ray_flow_expectation.hpp"

#include <algorithm>
#include <numeric>

namespace rayline {

std::size_t warm_start(Schedule& s, const JobPool& pool, const std::vector<BlockId>& blocks, const std::vector<double>& use,
                       const WarmStart& opt) {
  const DeviceGraph& g = s.graph();
  std::vector<std::size_t> order(blocks.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return use[a] > use[b]; });
  std::size_t placed = 0;
  for (std::size_t m = 0; m < g.memories.size(); ++m) {
    const auto mem = static_cast<MemId>(m);
    const MemoryDevice& md = g.memories[m];
    if (md.kind == MemoryKind::Disk || g.computes_on(mem).empty()) continue;
    const double share = md.kind == MemoryKind::Gpu ? opt.gpu_share : opt.host_share;
    const auto room = static_cast<Bytes>(std::max(0.0, share) * static_cast<double>(md.capacity));
    for (std::size_t i : order) {
      const BlockId b = blocks[i];
      const Bytes bytes = pool.block(b).bytes;
      if (s.copy_at(b, mem) || s.used(mem) + bytes > room) continue;
      s.put_initial(b, mem, 0, false);
      ++placed;
    }
  }
  return placed;
}

std::vector<double> expected_block_visits(const SceneProfile& p) {
  const RayFlowExpectation e = expected_ray_flow(p, Fidelity::Markov);
  std::vector<double> visits(e.intersect.size());
  for (std::size_t b = 0; b < visits.size(); ++b) visits[b] = e.intersect[b] + e.shadow[b];
  return visits;
}

}  // namespace rayline

#include "workload/warm_start.hpp"

#include "workload/ray_flow_expectation.hpp"

#include <algorithm>
#include <numeric>

namespace rayline {

std::size_t warm_start(Schedule& s, const JobPool& pool, const std::vector<BlockId>& blocks, const std::vector<double>& use,
                       const WarmStart& opt) {
  const DeviceGraph& g = s.graph();
  auto room = [&](MemId mem) {
    const MemoryDevice& md = g.memories[static_cast<std::size_t>(mem)];
    const double share = md.kind == MemoryKind::Gpu ? opt.gpu_share : opt.host_share;
    return static_cast<Bytes>(std::max(0.0, share) * static_cast<double>(md.capacity));
  };
  std::size_t placed = 0;
  if (!opt.placement.empty()) {
    for (std::size_t i = 0; i < blocks.size() && i < opt.placement.size(); ++i)
      for (MemId mem : opt.placement[i]) {
        const BlockId b = blocks[i];
        if (s.copy_at(b, mem) || s.used(mem) + pool.block(b).bytes > room(mem)) continue;
        s.put_initial(b, mem, 0, false);
        ++placed;
      }
    return placed;
  }
  std::vector<std::size_t> order(blocks.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return use[a] > use[b]; });
  for (std::size_t m = 0; m < g.memories.size(); ++m) {
    const auto mem = static_cast<MemId>(m);
    const MemoryDevice& md = g.memories[m];
    if (md.kind == MemoryKind::Disk || g.computes_on(mem).empty()) continue;
    for (std::size_t i : order) {
      const BlockId b = blocks[i];
      const Bytes bytes = pool.block(b).bytes;
      if (s.copy_at(b, mem) || s.used(mem) + bytes > room(mem)) continue;
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

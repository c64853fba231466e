#include "workload/warm_start.hpp"

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
  const std::size_t n = p.blocks.size();
  std::vector<double> visits(n, 0.0), now(n, 0.0), next(n, 0.0);
  for (const CameraKey& k : p.camera_path)
    for (const auto& [b, prob] : k.entry)
      if (b >= 0 && static_cast<std::size_t>(b) < n) now[static_cast<std::size_t>(b)] += prob / static_cast<double>(p.camera_path.size());
  // Each step moves every ray once; a path has at most max_bounces surviving hits, and a
  // missed ray crosses at most a few hundred cells, so 4096 steps bound the walk.
  for (int step = 0; step < 4096; ++step) {
    double mass = 0;
    std::fill(next.begin(), next.end(), 0.0);
    for (std::size_t b = 0; b < n; ++b) {
      const double v = now[b];
      if (v <= 0) continue;
      visits[b] += v;
      const ProfileBlock& pb = p.blocks[b];
      next[b] += v * pb.alpha * pb.beta;  // a hit that survives: its next ray starts here
      const double onward = v * (1 - pb.alpha) * (1 - pb.escape);
      for (const ProfileNeighbour& nb : pb.neighbours)
        if (nb.block >= 0 && static_cast<std::size_t>(nb.block) < n) next[static_cast<std::size_t>(nb.block)] += onward * nb.p;
    }
    for (double v : next) mass += v;
    now.swap(next);
    if (mass < 1e-9) break;
  }
  return visits;
}

}  // namespace rayline

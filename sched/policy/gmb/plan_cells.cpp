#include "sched/policy/gmb/plan_cells.hpp"

#include <algorithm>
#include <tuple>

#include "sched/policy/placer.hpp"

namespace rayline {

void PlanCells::build(const DeviceGraph& g, int cell_nodes) {
  // Nodes in rack order (the first network with racks), then the nodes in no rack, each
  // run cut into cells of at most cell_nodes consecutive nodes.
  std::vector<std::int32_t> cell_of_node(g.nodes.size(), kNone);
  n_cells_ = 0;
  if (cell_nodes > 0 && g.nodes.size() > static_cast<std::size_t>(cell_nodes)) {
    std::vector<std::vector<NodeId>> runs;
    std::vector<char> placed(g.nodes.size(), 0);
    for (const Network& net : g.networks) {
      if (net.racks.empty()) continue;
      std::vector<std::vector<NodeId>> by_rack(net.racks.size());
      for (const NetworkMember& mb : net.members)
        if (mb.rack != kNone && mb.node != kNone && !placed[static_cast<std::size_t>(mb.node)]) {
          by_rack[static_cast<std::size_t>(mb.rack)].push_back(mb.node);
          placed[static_cast<std::size_t>(mb.node)] = 1;
        }
      for (auto& r : by_rack)
        if (!r.empty()) runs.push_back(std::move(r));
    }
    std::vector<NodeId> rest;
    for (std::size_t n = 0; n < g.nodes.size(); ++n)
      if (!placed[n]) rest.push_back(static_cast<NodeId>(n));
    if (!rest.empty()) runs.push_back(std::move(rest));
    for (const auto& run : runs)
      for (std::size_t k = 0; k < run.size(); ++k) {
        if (k % static_cast<std::size_t>(cell_nodes) == 0) ++n_cells_;
        cell_of_node[static_cast<std::size_t>(run[k])] = n_cells_ - 1;
      }
  }
  if (n_cells_ <= 1) {
    n_cells_ = 1;
    std::fill(cell_of_node.begin(), cell_of_node.end(), 0);
  }
  const auto cells = static_cast<std::size_t>(n_cells_);
  cell_of_mem_.assign(g.memories.size(), 0);
  mems_of_cell_.assign(cells, {});
  devices_of_cell_.assign(cells, {});
  types_of_cell_.assign(cells, 0);
  for (std::size_t m = 0; m < g.memories.size(); ++m) {
    const NodeId n = g.memories[m].node;
    const std::int32_t c = n < 0 || static_cast<std::size_t>(n) >= cell_of_node.size() ? 0 : cell_of_node[static_cast<std::size_t>(n)];
    cell_of_mem_[m] = c;
    mems_of_cell_[static_cast<std::size_t>(c)].push_back(static_cast<MemId>(m));
  }
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const std::int32_t c = cell_of_mem_[static_cast<std::size_t>(g.computes[d].memory)];
    devices_of_cell_[static_cast<std::size_t>(c)].push_back(static_cast<DeviceId>(d));
    for (int t = 0; t < g.timing.job_types() && t < 64; ++t)
      if (g.timing.supports(static_cast<DeviceId>(d), static_cast<JobTypeId>(t))) types_of_cell_[static_cast<std::size_t>(c)] |= std::uint64_t{1} << t;
  }
  for (JobId j : homed_) home_[static_cast<std::size_t>(j)] = kNone;
  homed_.clear();
}

// The cell of the job's least-replicated input: where its rays are (a ray queue has one
// copy), or, for an input still to be made, the memory of its producer's device.
std::int32_t PlanCells::locus_cell(const Job& job, const JobPool& pool, const Schedule& s) const {
  MemId best = kNone;
  std::size_t best_copies = 0;
  Bytes best_bytes = 0;
  for (BlockId b : job.inputs) {
    const std::vector<Copy>& copies = s.copies(b);
    MemId at = kNone;
    std::size_t n = copies.size();
    if (n > 0) {
      at = copies.front().mem;
    } else if (const JobId p = pool.producer(b); p != kNone && pool.activity(p) != kNone) {
      at = s.graph().computes[static_cast<std::size_t>(s.activity(pool.activity(p)).device)].memory;
      n = 1;
    }
    if (at == kNone) continue;
    const Bytes bytes = pool.block(b).bytes;
    if (best == kNone || n < best_copies || (n == best_copies && bytes > best_bytes)) {
      best = at;
      best_copies = n;
      best_bytes = bytes;
    }
  }
  return best == kNone ? kNone : cell_of_mem_[static_cast<std::size_t>(best)];
}

void PlanCells::assign(Time now, Time horizon, const JobPool& pool, const Schedule& s) {
  for (JobId j : homed_) home_[static_cast<std::size_t>(j)] = kNone;
  homed_.clear();
  moved_ = 0;
  if (n_cells_ <= 1) return;
  if (home_.size() < pool.job_count()) home_.resize(pool.job_count(), kNone);
  const DeviceGraph& g = s.graph();
  const auto cells = static_cast<std::size_t>(n_cells_);
  // Per cell: devices alive, queued work in device-seconds (planned and homed), and one
  // device per job type that estimates a job's T_EXEC there (Eq. 2).
  std::vector<double> n_dev(cells, 0), work(cells, 0);
  const int types = std::min(g.timing.job_types(), 64);
  std::vector<DeviceId> rep(cells * static_cast<std::size_t>(types), kNone);
  for (std::size_t c = 0; c < cells; ++c)
    for (DeviceId d : devices_of_cell_[c]) {
      if (!s.compute_alive(d)) continue;
      n_dev[c] += 1;
      work[c] += std::max(0.0, s.device_timeline(d).busy_until - now);
      for (int t = 0; t < types; ++t)
        if (rep[c * static_cast<std::size_t>(types) + static_cast<std::size_t>(t)] == kNone && g.timing.supports(d, static_cast<JobTypeId>(t)))
          rep[c * static_cast<std::size_t>(types) + static_cast<std::size_t>(t)] = d;
    }
  auto rep_of = [&](std::size_t c, JobTypeId t) {
    return t >= 0 && t < types ? rep[c * static_cast<std::size_t>(types) + static_cast<std::size_t>(t)] : kNone;
  };
  // Movable candidates per cell: (bytes to move, queue order, job), smallest data first.
  std::vector<std::vector<std::tuple<Bytes, std::size_t, JobId>>> movable(cells);
  std::size_t order = 0;
  for (JobId j : pool.queued()) {
    ++order;
    const Job& job = pool.job(j);
    const std::int32_t c = locus_cell(job, pool, s);
    if (c == kNone) continue;
    const DeviceId d = rep_of(static_cast<std::size_t>(c), job.type);
    if (d == kNone || !s.compute_alive(d)) continue;  // no device of the cell runs it: any cell
    home_[static_cast<std::size_t>(j)] = c;
    homed_.push_back(j);
    work[static_cast<std::size_t>(c)] += Placer::exec_estimate(j, d, s);
    Bytes bytes = 0;
    bool can_move = true;
    for (BlockId b : job.inputs) {
      const DataBlock& blk = pool.block(b);
      if (!blk.movable) can_move = false;
      if (s.copies(b).size() <= 1) bytes += blk.bytes;
    }
    if (can_move) movable[static_cast<std::size_t>(c)].emplace_back(bytes, order, j);
  }
  for (auto& v : movable) std::sort(v.begin(), v.end());
  std::vector<std::size_t> next(cells, 0);
  // Balance: while the cell that runs dry first (least work per device) would run dry
  // within the horizon, give it the smallest movable job of the cell with the most work
  // per device, as long as that narrows the gap.
  auto load = [&](std::size_t c) { return n_dev[c] > 0 ? work[c] / n_dev[c] : kNever; };
  for (;;) {
    std::size_t lo = cells, hi = cells;
    for (std::size_t c = 0; c < cells; ++c) {
      if (n_dev[c] == 0) continue;
      if (lo == cells || load(c) < load(lo)) lo = c;
      if (next[c] < movable[c].size() && (hi == cells || load(c) > load(hi))) hi = c;
    }
    if (lo == cells || hi == cells || lo == hi || !(load(lo) < horizon)) break;
    const JobId j = std::get<2>(movable[hi][next[hi]]);
    ++next[hi];
    const Job& job = pool.job(j);
    const DeviceId dl = rep_of(lo, job.type), dh = rep_of(hi, job.type);
    if (dl == kNone || dh == kNone) continue;
    const Time wl = Placer::exec_estimate(j, dl, s), wh = Placer::exec_estimate(j, dh, s);
    if (!(load(hi) - wh / n_dev[hi] > load(lo) + wl / n_dev[lo])) break;  // no longer narrows the gap
    work[hi] -= wh;
    work[lo] += wl;
    home_[static_cast<std::size_t>(j)] = static_cast<std::int32_t>(lo);
    ++moved_;
  }
}

}  // namespace rayline

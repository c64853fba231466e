#include "sched/policy/load_any_once.hpp"

#include <algorithm>
#include <chrono>
#include <map>

namespace rayline {

std::vector<std::int32_t> load_any_once_assign(const std::vector<std::uint64_t>& demand, int ranks) {
  return load_any_once_assign(demand, ranks, [](int, std::int32_t) { return true; });
}

std::vector<std::int32_t> load_any_once_assign(const std::vector<std::uint64_t>& demand, int ranks,
                                               const std::function<bool(int rank, std::int32_t domain)>& can) {
  std::vector<std::int32_t> order;
  for (std::size_t d = 0; d < demand.size(); ++d)
    if (demand[d] > 0) order.push_back(static_cast<std::int32_t>(d));
  // GraviT sorts (count << 7) + id ascending and pops from the back: highest count first,
  // equal counts by higher id first. (Pairs here, so no 32-bit overflow of that key.)
  std::sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
    if (demand[static_cast<std::size_t>(a)] != demand[static_cast<std::size_t>(b)])
      return demand[static_cast<std::size_t>(a)] > demand[static_cast<std::size_t>(b)];
    return a > b;
  });
  std::vector<std::int32_t> map(static_cast<std::size_t>(std::max(0, ranks)), kNone);
  std::size_t first_free = 0;  // ranks before it are all taken
  for (const std::int32_t dom : order) {
    while (first_free < map.size() && map[first_free] != kNone) ++first_free;
    if (first_free == map.size()) break;
    for (std::size_t r = first_free; r < map.size(); ++r)
      if (map[r] == kNone && can(static_cast<int>(r), dom)) {
        map[r] = dom;
        break;
      }
  }
  return map;
}

PlanStats LoadAnyOnceScheduler::plan(Time now, JobPool& pool, Schedule& s) {
  const auto t0 = std::chrono::steady_clock::now();
  PlanStats st;
  if (s.unfinished() > 0) return st;  // bulk-synchronous: wait for every rank
  if (bound_ != &s || !placer_) {
    placer_ = std::make_unique<Placer>(s);
    bound_ = &s;
  }
  s.reproject(now);
  placer_->finder().clear();
  placer_->finder().set_now(now);
  placer_->finder().set_scene_from_origin_or_local(true);
  ++rounds_;
  // Domains: each queued job's SceneData input (else its largest input); demand in rays
  // (work units, or ray-queue bytes when a job states no work).
  std::map<BlockId, std::int32_t> index;
  std::vector<BlockId> domain;
  std::vector<std::uint64_t> demand;
  std::vector<std::vector<JobId>> jobs;
  for (JobId j : pool.queued()) {
    const Job& job = pool.job(j);
    // Only rays that exist count (GraviT counts queued rays): a job that must follow one
    // not yet planned, or whose input is not produced yet, waits for a later round.
    if (s.after_deps_ready(j) == kNever) continue;
    bool produced = true;
    for (BlockId b : job.inputs) produced = produced && !s.copies(b).empty();
    if (!produced) continue;
    BlockId key = kNone;
    std::uint64_t rays = 0;
    for (BlockId b : job.inputs) {
      const DataBlock& blk = pool.block(b);
      if (blk.kind == DataKind::SceneData) key = b;
      else rays += blk.bytes;
    }
    if (key == kNone)
      for (BlockId b : job.inputs)
        if (key == kNone || pool.block(b).bytes > pool.block(key).bytes) key = b;
    if (job.work > 0) rays = job.work;
    auto [it, fresh] = index.emplace(key, static_cast<std::int32_t>(domain.size()));
    if (fresh) {
      domain.push_back(key);
      demand.push_back(0);
      jobs.emplace_back();
    }
    demand[static_cast<std::size_t>(it->second)] += std::max<std::uint64_t>(1, rays);
    jobs[static_cast<std::size_t>(it->second)].push_back(j);
  }
  const DeviceGraph& g = s.graph();
  // Over the devices still alive (Schedule::fail): a lost one is given no domain.
  std::vector<DeviceId> live;
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    if (s.compute_alive(static_cast<DeviceId>(d))) live.push_back(static_cast<DeviceId>(d));
  // A rank can run a domain when its device runs the type of one of the domain's jobs.
  // (Where the device's memory lacks a job's input that cannot move, a client's
  // framebuffer, the job still waits for a round that maps its domain to a device there.)
  const auto can = [&](int r, std::int32_t dom) {
    const DeviceId d = live[static_cast<std::size_t>(r)];
    for (JobId j : jobs[static_cast<std::size_t>(dom)])
      if (g.timing.supports(d, pool.job(j).type)) return true;
    return false;
  };
  const auto map = load_any_once_assign(demand, static_cast<int>(live.size()), can);
  for (std::size_t r = 0; r < map.size(); ++r) {
    if (map[r] == kNone) continue;
    const DeviceId d = live[r];
    for (JobId j : jobs[static_cast<std::size_t>(map[r])]) {
      if (!g.timing.supports(d, pool.job(j).type)) continue;
      const Time ready = std::max(now, s.device_timeline(d).busy_until);
      if (placer_->earliest_start(j, d, ready, s) == kNever) continue;  // e.g. input unreachable
      placer_->place(j, d, ready, now, pool, s, st);
    }
  }
  st.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace rayline

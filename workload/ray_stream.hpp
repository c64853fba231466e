// A synthetic ray-batching stream (the simple workload; the path-tracing workload
// plugs into the same seam). Scene blocks sit on every node's disk (Sec. 6.1).
// Ray queues appear over time and rays spawn rays, so the jobs of the next second are
// unknown when planning (Sec. 3.1):
//   * a RayIntersect on block b with R rays leaves (1-alpha)R rays that missed b and go to
//     a neighbour block, and alpha*beta*R surviving secondary rays that stay on b; both
//     are output RayQueues on the memory device where the job ran;
//   * new primary batches keep `backlog` jobs queued, so every device can be busy;
//   * a queue produced where a queued job already holds a queue for the same block merges
//     into it (Sec. 5.1).
// Deterministic for a seed (its own 64-bit generator, no std:: distributions).
#pragma once
#include <map>
#include <vector>

#include "sched/core/device_graph.hpp"
#include "sched/runtime/workload.hpp"
#include "workload/warm_start.hpp"

namespace rayline {

struct RayStreamOptions {
  int blocks = 129;
  Bytes scene_bytes = Bytes(26.5 * 1024 * 1024 * 1024.0);
  Bytes ray_bytes = 64;
  int backlog = 0;                 // queued jobs kept (0: two per compute device)
  double rays_min = 1e5, rays_max = 1e6;  // per new primary batch
  double alpha = 0.6;              // hit ratio
  double beta = 0.5;               // survival (Russian roulette)
  double min_rays = 1000;          // smaller spawned queues are dropped (path ends)
  Time stop_new_batches = kNever;  // no new primary batches after this time
  std::uint64_t seed = 1;
  // Warm start (warm_start.hpp): memories begin holding the most popular blocks (Zipf).
  bool warm = false;
  WarmStart warm_start;
};

class RayStreamWorkload final : public Workload {
 public:
  RayStreamWorkload(const DeviceGraph& g, RayStreamOptions opt);
  void start(Time now, JobPool& pool, Schedule& schedule) override;
  void on_job_finished(JobId job, Time now, JobPool& pool, Schedule& schedule) override;
  bool finished() const override { return stopped_; }
  // A stream goes on after a fault (docs/faults.md): the rays of lost jobs are counted, and
  // new batches appear only on host memories still alive.
  void on_lost(Time now, const std::vector<JobId>& jobs, const std::vector<BlockId>& blocks, JobPool& pool,
               Schedule& schedule) override;
  std::uint64_t rays_lost() const { return rays_lost_; }

  std::uint64_t rays_traced() const { return rays_traced_; }
  std::uint64_t merges() const { return merges_; }
  std::uint64_t primary_rays() const { return primary_rays_; }  // rays of new batches
  std::uint64_t spawned_rays() const { return spawned_rays_; }  // rays in output queues
  // (time, rays) of every finished RayIntersect, for throughput over time.

 private:
  double uniform();
  void top_up(Time now, JobPool& pool, Schedule& schedule);
  void add_queue(int block, std::uint64_t rays, MemId where, BlockId produced, Time now, JobPool& pool, Schedule& s);
  BlockId new_queue_block(int block, std::uint64_t rays, JobPool& pool);

  const DeviceGraph& g_;
  RayStreamOptions opt_;
  std::uint64_t state_;
  JobTypeId type_ = kNone;
  std::vector<BlockId> scene_;
  std::vector<MemId> hosts_, disks_;
  std::map<std::pair<int, MemId>, JobId> open_;  // (block, memory) -> queued job holding a queue there
  std::vector<int> job_block_;
  std::vector<MemId> job_queue_mem_;
  std::uint64_t rays_traced_ = 0, merges_ = 0, primary_rays_ = 0, spawned_rays_ = 0, rays_lost_ = 0;
  bool stopped_ = false;
};

}  // namespace rayline

// JobPool: every data block and E-job of a run, plus the global job queue of Sec. 4.2
// ("whenever a new job is created, we push it to a global job queue").
#pragma once
#include <span>
#include <vector>

#include "data_block.hpp"
#include "job.hpp"

namespace rayline {

class JobPool {
 public:
  BlockId add_block(DataBlock b);
  JobId add_job(Job j);  // enters the queue; records it as producer of its outputs

  std::size_t block_count() const { return blocks_.size(); }
  std::size_t job_count() const { return jobs_.size(); }
  const DataBlock& block(BlockId b) const { return blocks_[b]; }
  DataBlock& block(BlockId b) { return blocks_[b]; }
  const Job& job(JobId j) const { return jobs_[j]; }
  Job& job(JobId j) { return jobs_[j]; }
  JobState state(JobId j) const { return state_[j]; }
  ActivityId activity(JobId j) const { return activity_[j]; }  // its E-job activity once planned
  JobId producer(BlockId b) const { return producer_[b]; }     // kNone: initial data

  // The global job queue (unplanned jobs), in arrival order.
  std::span<const JobId> queued() const { return queue_; }
  std::size_t queued_count() const { return queue_.size(); }

  void mark_planned(JobId j, ActivityId a);
  void mark_done(JobId j);
  void mark_discarded(JobId j);  // Sec. 5.2: a predicted job that did not happen
  void requeue(JobId j);         // a planned job whose activity was cancelled/failed
  // Sec. 5.1: a ray queue arriving where a queued job already holds one for the same block
  // merges into it: the block becomes one more input of that (still unplanned) job.
  void add_input(JobId j, BlockId b);

  // Queued jobs that read block b (eviction value: data still wanted by the queue).
  int queued_demand(BlockId b) const { return demand_[b]; }

 private:
  void remove_from_queue(JobId j);
  std::vector<DataBlock> blocks_;
  std::vector<JobId> producer_;
  std::vector<int> demand_;
  std::vector<Job> jobs_;
  std::vector<JobState> state_;
  std::vector<ActivityId> activity_;
  std::vector<std::int32_t> queue_pos_;  // -1: not queued; else an upper bound on its index in queue_
  std::vector<JobId> queue_;
};

}  // namespace rayline

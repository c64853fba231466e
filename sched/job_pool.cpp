#include "sched/job_pool.hpp"

#include <algorithm>
#include <stdexcept>

namespace rayline {

BlockId JobPool::add_block(DataBlock b) {
  blocks_.push_back(std::move(b));
  producer_.push_back(kNone);
  demand_.push_back(0);
  return static_cast<BlockId>(blocks_.size() - 1);
}

JobId JobPool::add_job(Job j) {
  const auto id = static_cast<JobId>(jobs_.size());
  for (BlockId o : j.outputs) {
    if (producer_.at(o) != kNone) throw std::logic_error("block produced by two jobs: " + blocks_[o].name);
    producer_[o] = id;
  }
  for (BlockId i : j.inputs) ++demand_.at(i);
  jobs_.push_back(std::move(j));
  state_.push_back(JobState::Queued);
  activity_.push_back(kNone);
  queue_pos_.push_back(static_cast<std::int32_t>(queue_.size()));
  queue_.push_back(id);
  return id;
}

void JobPool::remove_from_queue(JobId j) {
  if (queue_pos_[j] < 0) return;
  // queue_pos_ is where j was appended; erasures before it only move it to the front, so
  // it is found looking back from there (no positions to rewrite after an erase).
  auto pos = std::min(static_cast<std::size_t>(queue_pos_[j]), queue_.size() - 1);
  while (queue_[pos] != j) --pos;
  // Order-preserving erase keeps planning deterministic and FIFO-fair among equals.
  queue_.erase(queue_.begin() + static_cast<std::ptrdiff_t>(pos));
  queue_pos_[j] = -1;
  for (BlockId i : jobs_[j].inputs) --demand_[i];
}

void JobPool::mark_planned(JobId j, ActivityId a) {
  remove_from_queue(j);
  state_[j] = JobState::Planned;
  activity_[j] = a;
}

void JobPool::mark_done(JobId j) { state_[j] = JobState::Done; }

void JobPool::mark_discarded(JobId j) {
  remove_from_queue(j);
  state_[j] = JobState::Discarded;
}

void JobPool::add_input(JobId j, BlockId b) {
  if (state_[j] != JobState::Queued) throw std::logic_error("can only merge into a queued job");
  jobs_[j].inputs.push_back(b);
  ++demand_.at(b);
}

void JobPool::requeue(JobId j) {
  if (queue_pos_[j] >= 0) return;
  state_[j] = JobState::Queued;
  activity_[j] = kNone;
  queue_pos_[j] = static_cast<std::int32_t>(queue_.size());
  queue_.push_back(j);
  for (BlockId i : jobs_[j].inputs) ++demand_[i];
}

}  // namespace rayline

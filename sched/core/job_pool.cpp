#include "sched/core/job_pool.hpp"

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
  input_count_.push_back(static_cast<std::uint32_t>(j.inputs.size()));
  jobs_.push_back(std::move(j));
  state_.push_back(JobState::Queued);
  activity_.push_back(kNone);
  queue_pos_.push_back(appended_);
  queue_.push_back({appended_++, id});
  return id;
}

std::size_t JobPool::first_numbered(std::int64_t number) const {
  const auto it = std::lower_bound(queue_.begin(), queue_.end(), number,
                                   [](const Entry& e, std::int64_t n) { return e.number < n; });
  return static_cast<std::size_t>(it - queue_.begin());
}

void JobPool::remove_from_queue(JobId j) {
  if (queue_pos_[j] < 0) return;
  queue_[first_numbered(queue_pos_[j])].job = kNone;  // a hole: the order of the rest is kept (deterministic, FIFO-fair)
  queue_pos_[j] = -1;
  left_queue_.push_back(j);
  for (BlockId i : jobs_[j].inputs) --demand_[i];
  if (++holes_ * 2 > queue_.size() && queue_.size() > 64) {
    std::erase_if(queue_, [](const Entry& e) { return e.job == kNone; });
    holes_ = 0;
  }
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
  merged_.push_back(j);
  ++input_count_[j];
  ++demand_.at(b);
}

void JobPool::requeue(JobId j) {
  if (queue_pos_[j] >= 0) return;
  state_[j] = JobState::Queued;
  activity_[j] = kNone;
  queue_pos_[j] = appended_;
  queue_.push_back({appended_++, j});
  for (BlockId i : jobs_[j].inputs) ++demand_[i];
}

}  // namespace rayline

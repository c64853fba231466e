// JobPool: every data block and E-job of a run, plus the global job queue of Sec. 4.2
// ("whenever a new job is created, we push it to a global job queue").
#pragma once
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <vector>

#include "sched/core/data_block.hpp"
#include "sched/core/job.hpp"

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
  // How many inputs job j has: job(j).inputs.size(), from a dense array (a policy that
  // caches what a queued job's inputs say checks it for merges without reading the Job).
  std::uint32_t input_count(JobId j) const { return input_count_[j]; }
  ActivityId activity(JobId j) const { return activity_[j]; }  // its E-job activity once planned
  JobId producer(BlockId b) const { return producer_[b]; }     // kNone: initial data

  // The global job queue (unplanned jobs), in arrival order: a forward range of JobId.
  class Queue;
  Queue queued() const;
  std::size_t queued_count() const { return queue_.size() - holes_; }
  // A queued job's append number (increasing along the queue; a requeued job gets a new
  // one), -1 when it is not queued; and the queued jobs appended at or after `number`, in
  // queue order (a policy that keeps its own view of the queue reads only what is new).
  std::int64_t queue_number(JobId j) const { return queue_pos_[j]; }
  Queue queued_since(std::int64_t number) const;
  std::int64_t appended() const { return appended_; }

  void mark_planned(JobId j, ActivityId a);
  void mark_done(JobId j);
  void mark_discarded(JobId j);  // Sec. 5.2: a predicted job that did not happen
  void requeue(JobId j);         // a planned job whose activity was cancelled/failed
  // Sec. 5.1: a ray queue arriving where a queued job already holds one for the same block
  // merges into it: the block becomes one more input of that (still unplanned) job.
  void add_input(JobId j, BlockId b);
  // The jobs that took an input by add_input, one entry per merge, in order (a policy reads
  // those since its last look).
  const std::vector<JobId>& merged() const { return merged_; }
  // The jobs that left the queue (planned or discarded), one entry each time, in order.
  const std::vector<JobId>& left_queue() const { return left_queue_; }

  // Queued jobs that read block b (eviction value: data still wanted by the queue).
  int queued_demand(BlockId b) const { return demand_[b]; }

 private:
  void remove_from_queue(JobId j);
  std::size_t first_numbered(std::int64_t number) const;  // the first queue entry numbered >= number
  std::vector<JobId> merged_, left_queue_;
  std::vector<DataBlock> blocks_;
  std::vector<JobId> producer_;
  std::vector<int> demand_;
  std::vector<Job> jobs_;
  std::vector<JobState> state_;
  std::vector<std::uint32_t> input_count_;
  std::vector<ActivityId> activity_;
  // The queue keeps its arrival order. A job leaving it leaves a hole (job kNone), so no
  // removal moves the rest (a plan takes hundreds of jobs out of a queue of thousands);
  // holes are squeezed out once they are the majority. Each entry keeps its append number,
  // increasing along the queue, so a job is found by binary search.
  struct Entry {
    std::int64_t number;
    JobId job;
  };
  std::vector<std::int64_t> queue_pos_;  // per job: -1 when not queued, else its append number
  std::int64_t appended_ = 0;
  std::vector<Entry> queue_;
  std::size_t holes_ = 0;
};

// JobPool::queued(): the queue's jobs, skipping holes.
class JobPool::Queue {
 public:
  class iterator {
   public:
    using value_type = JobId;
    using difference_type = std::ptrdiff_t;
    using reference = JobId;  // (ids by value)
    using pointer = void;
    using iterator_category = std::input_iterator_tag;
    using iterator_concept = std::forward_iterator_tag;
    iterator() = default;
    iterator(const Entry* p, const Entry* end) : p_(p), end_(end) { skip(); }
    JobId operator*() const { return p_->job; }
    iterator& operator++() {
      ++p_;
      skip();
      return *this;
    }
    iterator operator++(int) {
      iterator t = *this;
      ++*this;
      return t;
    }
    bool operator==(const iterator& o) const { return p_ == o.p_; }

   private:
    void skip() {
      while (p_ != end_ && p_->job == kNone) ++p_;
    }
    const Entry* p_ = nullptr;
    const Entry* end_ = nullptr;
  };
  Queue(const Entry* begin, const Entry* end) : begin_(begin), end_(end) {}
  iterator begin() const { return {begin_, end_}; }
  iterator end() const { return {end_, end_}; }

 private:
  const Entry* begin_;
  const Entry* end_;
};

inline JobPool::Queue JobPool::queued() const { return {queue_.data(), queue_.data() + queue_.size()}; }
inline JobPool::Queue JobPool::queued_since(std::int64_t number) const {
  return {queue_.data() + first_numbered(number), queue_.data() + queue_.size()};
}

}  // namespace rayline

#include "sched/bucket_heap.hpp"

#include <algorithm>

namespace rayline {

void BucketHeap::reset(std::size_t buckets) {
  heap_.clear();
  gen_.assign(buckets, 0);
  deferred_.clear();
}

void BucketHeap::pop() {
  std::pop_heap(heap_.begin(), heap_.end(), later);
  heap_.pop_back();
}

// Buckets (holder groups) appear one at a time during a pass: gen_ grows geometrically
// (an unused slot's generation 0 is never read).
void BucketHeap::grow(std::int32_t bucket) {
  gen_.resize(std::max(static_cast<std::size_t>(bucket) + 1, 2 * gen_.size()), 0);
}

void BucketHeap::push(std::int32_t bucket, Time key, std::uint64_t stamp) {
  if (static_cast<std::size_t>(bucket) >= gen_.size()) grow(bucket);
  const std::uint32_t g = ++gen_[static_cast<std::size_t>(bucket)];
  heap_.push_back({key, bucket, g, stamp});
  std::push_heap(heap_.begin(), heap_.end(), later);
}

void BucketHeap::defer(std::int32_t bucket) {
  if (static_cast<std::size_t>(bucket) >= gen_.size()) grow(bucket);
  deferred_.emplace_back(bucket, ++gen_[static_cast<std::size_t>(bucket)]);
}

void BucketHeap::restore(const Entry& e) {
  heap_.push_back(e);
  std::push_heap(heap_.begin(), heap_.end(), later);
}

}  // namespace rayline

#include "sched/policy/gmb/bucket_order.hpp"

namespace rayline {

void BucketOrder::reset(std::size_t buckets) {
  order_.clear();
  gen_.assign(buckets, 0);
  placed_.assign(buckets, 0);
  stale_ = 0;
  deferred_.clear();
}

// Buckets (holder groups) appear one at a time during a pass: gen_ grows geometrically
// (an unused slot's generation 0 is never read). Superseding a placed entry leaves it
// stale; once stale entries are half the array, it is compacted.
std::uint32_t BucketOrder::supersede(std::int32_t bucket) {
  const auto b = static_cast<std::size_t>(bucket);
  if (b >= gen_.size()) {
    gen_.resize(std::max(b + 1, 2 * gen_.size()), 0);
    placed_.resize(gen_.size(), 0);
  }
  if (placed_[b]) {
    placed_[b] = 0;
    if (++stale_ > order_.size() / 2 && stale_ > 8) {
      std::erase_if(order_, [&](const Entry& e) { return gen_[static_cast<std::size_t>(e.bucket)] != e.gen || e.bucket == bucket; });
      stale_ = 0;
    }
  }
  return ++gen_[b];
}

void BucketOrder::insert(const Entry& e) {
  placed_[static_cast<std::size_t>(e.bucket)] = 1;
  order_.insert(std::upper_bound(order_.begin(), order_.end(), e, before), e);
}

void BucketOrder::push(std::int32_t bucket, Time key, std::uint64_t stamp) {
  insert({key, bucket, supersede(bucket), stamp});
}

void BucketOrder::rekey(std::size_t i, Time key, std::uint64_t stamp) {
  Entry e = order_[i];
  e.key = key;
  e.stamp = stamp;
  // (key > the old key: the new place is after i.)
  const auto from = order_.begin() + static_cast<std::ptrdiff_t>(i);
  const auto to = std::upper_bound(from + 1, order_.end(), e, before);
  std::move(from + 1, to, from);
  *(to - 1) = e;
}

void BucketOrder::erase(std::size_t i) {
  if (current(i)) placed_[static_cast<std::size_t>(order_[i].bucket)] = 0;
  else --stale_;
  order_.erase(order_.begin() + static_cast<std::ptrdiff_t>(i));
}

void BucketOrder::defer(std::int32_t bucket) { deferred_.emplace_back(bucket, supersede(bucket)); }

}  // namespace rayline

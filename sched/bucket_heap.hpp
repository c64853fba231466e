// Per-memory-device order of GMB's selection buckets (Sec. 4.3 job selection, issue 2
// planning speed). A bucket groups the queued jobs that share their largest input (the
// "key" block); no job of bucket k can start on memory device m before key(k) reaches m,
// so a lower bound on that arrival (FetchBound, Eq. 3's last hop, or an earlier exact SDC
// arrival: within a planning pass arrivals only grow while the block's holders stay the
// same) orders the buckets, and selection visits them cheapest first until the bound
// loses to the best job found.
//
// The heap persists across the selections of one plan. Its keys are allowed to go stale
// in one direction only: a key may be lower than the bucket's current bound (commits only
// delay fetches), and is then raised lazily when the bucket reaches the top. What can
// lower a bound (a new copy of the key block) re-inserts the bucket with key -inf, which
// supersedes every older entry of that bucket.
#pragma once
#include <cstdint>
#include <utility>
#include <vector>

#include "types.hpp"

namespace rayline {

class BucketHeap {
 public:
  struct Entry {
    Time key;
    std::int32_t bucket;
    std::uint32_t gen;
    std::uint64_t stamp = 0;  // the caller's: e.g. when `key` was computed (0: never)
  };
  void reset(std::size_t buckets);
  bool empty() const { return heap_.empty(); }
  const Entry& top() const { return heap_.front(); }
  void pop();
  // Insert (or supersede) bucket's entry.
  void push(std::int32_t bucket, Time key, std::uint64_t stamp = 0);
  // Put back an entry taken off by pop() that is still its bucket's newest.
  void restore(const Entry& e);
  // push(bucket, -inf) without the heap work: the bucket's entry is superseded now and
  // its key computed by the next settle(). An entry keyed -inf would leave the top only
  // to be re-keyed, before any finite key is looked at, so this orders the same.
  void defer(std::int32_t bucket);
  // Every bucket deferred since (and not superseded again) enters with key_of(bucket),
  // stamped stamp_of(bucket).
  template <class KeyOf, class StampOf>
  void settle(const KeyOf& key_of, const StampOf& stamp_of) {
    for (const auto& [bucket, gen] : deferred_)
      if (gen_[static_cast<std::size_t>(bucket)] == gen) push(bucket, key_of(bucket), stamp_of(bucket));
    deferred_.clear();
  }
  bool current(const Entry& e) const { return gen_[static_cast<std::size_t>(e.bucket)] == e.gen; }

 private:
  struct Later {  // min-heap on (key, bucket)
    bool operator()(const Entry& a, const Entry& b) const { return a.key != b.key ? a.key > b.key : a.bucket > b.bucket; }
  };
  static constexpr Later later{};
  void grow(std::int32_t bucket);
  std::vector<Entry> heap_;
  std::vector<std::uint32_t> gen_;
  std::vector<std::pair<std::int32_t, std::uint32_t>> deferred_;  // (bucket, gen)
};

}  // namespace rayline

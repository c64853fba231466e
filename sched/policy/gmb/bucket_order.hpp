// Per-memory-device order of GMB's selection buckets (Sec. 4.3 job selection;
// planning speed). A bucket (here: a holder group of key blocks, arrival_bound.hpp) gets
// a lower bound on when any of its jobs can start on memory device m; selection visits
// the buckets cheapest first until the bound loses to the best job found.
//
// The order persists across the selections of one plan. Its keys may go stale in one
// direction only: a key may be lower than the bucket's current bound (commits only delay
// fetches) and is raised when a scan reaches it (rekey). What can lower a bound (a new
// member, a new copy) defers the bucket: its entry is superseded now and re-keyed by the
// next settle(), before any key is looked at.
//
// Entries are kept sorted by (key, bucket) in one array (a few dozen buckets per memory
// device): a selection scans it in order and leaves the buckets it visited in place, where
// a binary heap would pop each and push it back afterwards (two O(log n) sifts per visited
// bucket, the commonest operation). Superseded entries are skipped and dropped lazily.
#pragma once
#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "sched/core/types.hpp"

namespace rayline {

class BucketOrder {
 public:
  struct Entry {
    Time key;
    std::int32_t bucket;
    std::uint32_t gen;
    std::uint64_t stamp = 0;  // the caller's: e.g. what `key` was computed from (0: never)
  };
  void reset(std::size_t buckets);
  std::size_t size() const { return order_.size(); }
  const Entry& at(std::size_t i) const { return order_[i]; }
  // Is entry i its bucket's newest (else superseded: erase it)?
  bool current(std::size_t i) const {
    const Entry& e = order_[i];
    return gen_[static_cast<std::size_t>(e.bucket)] == e.gen;
  }
  // Insert (or supersede) bucket's entry.
  void push(std::int32_t bucket, Time key, std::uint64_t stamp = 0);
  // Entry i's bucket gets a larger key (and stamp): it moves later, the entries after it
  // up to its new place move one ahead.
  void rekey(std::size_t i, Time key, std::uint64_t stamp);
  void erase(std::size_t i);
  // Supersede bucket's entry now; its new key is computed by the next settle().
  void defer(std::int32_t bucket);
  // Every bucket deferred since (and not superseded again) enters with key_of(bucket),
  // stamped stamp_of(bucket).
  template <class KeyOf, class StampOf>
  void settle(const KeyOf& key_of, const StampOf& stamp_of) {
    for (const auto& [bucket, gen] : deferred_)
      if (gen_[static_cast<std::size_t>(bucket)] == gen) insert({key_of(bucket), bucket, gen, stamp_of(bucket)});
    deferred_.clear();
  }

 private:
  static bool before(const Entry& a, const Entry& b) { return a.key != b.key ? a.key < b.key : a.bucket < b.bucket; }
  void insert(const Entry& e);
  std::uint32_t supersede(std::int32_t bucket);  // the bucket's next generation
  std::vector<Entry> order_;  // sorted by before()
  std::vector<std::uint32_t> gen_;
  std::vector<char> placed_;  // per bucket: its current entry is in order_
  std::size_t stale_ = 0;     // superseded entries still in order_
  std::vector<std::pair<std::int32_t, std::uint32_t>> deferred_;  // (bucket, gen)
};

}  // namespace rayline

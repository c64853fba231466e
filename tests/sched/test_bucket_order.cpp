// BucketOrder (sched/policy/gmb/bucket_order.hpp) against a reference model: the current entry of
// every bucket in a std::map, scanned in (key, bucket) order. Random sequences of what GMB's
// selection does (push, defer, settle, scans that visit, raise and drop entries), with
// many equal keys so that ties are ordered by bucket.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "sched/policy/gmb/bucket_order.hpp"

namespace rayline {
namespace {

struct Reference {
  std::map<std::int32_t, std::pair<Time, std::uint64_t>> live;  // bucket -> (key, stamp)
  std::set<std::int32_t> deferred;
  std::vector<std::tuple<Time, std::int32_t, std::uint64_t>> sorted() const {
    std::vector<std::tuple<Time, std::int32_t, std::uint64_t>> v;
    for (const auto& [b, ks] : live) v.emplace_back(ks.first, b, ks.second);
    std::sort(v.begin(), v.end(), [](const auto& x, const auto& y) {
      return std::get<0>(x) != std::get<0>(y) ? std::get<0>(x) < std::get<0>(y) : std::get<1>(x) < std::get<1>(y);
    });
    return v;
  }
};

std::vector<std::tuple<Time, std::int32_t, std::uint64_t>> current_entries(const BucketOrder& o) {
  std::vector<std::tuple<Time, std::int32_t, std::uint64_t>> v;
  for (std::size_t k = 0; k < o.size(); ++k)
    if (o.current(k)) v.emplace_back(o.at(k).key, o.at(k).bucket, o.at(k).stamp);
  return v;
}

TEST(BucketOrder, ScansInKeyThenBucketOrderThroughRandomOperations) {
  for (std::uint32_t seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    auto key = [&] { return rng() % 3 == 0 ? static_cast<Time>(rng() % 8) : std::uniform_real_distribution<Time>(0, 8)(rng); };
    const std::int32_t buckets = 8 + static_cast<std::int32_t>(rng() % 40);
    BucketOrder o;
    Reference ref;
    o.reset(static_cast<std::size_t>(buckets / 2));  // later buckets grow it
    std::uint64_t stamp = 0;
    for (int step = 0; step < 600; ++step) {
      const std::int32_t b = static_cast<std::int32_t>(rng() % static_cast<std::uint32_t>(buckets));
      switch (rng() % 4) {
        case 0: {  // push: supersedes b's entry and any pending deferral
          const Time k = key();
          o.push(b, k, ++stamp);
          ref.live[b] = {k, stamp};
          ref.deferred.erase(b);
          break;
        }
        case 1:  // defer: b leaves the order until the next settle
          o.defer(b);
          ref.live.erase(b);
          ref.deferred.insert(b);
          break;
        case 2: {  // settle: every deferred bucket enters with its key
          std::map<std::int32_t, Time> keys;
          for (std::int32_t d : ref.deferred) keys[d] = key();
          o.settle([&](std::int32_t d) { return keys.at(d); }, [&](std::int32_t d) { return 1000u + static_cast<std::uint64_t>(d); });
          for (const auto& [d, k] : keys) ref.live[d] = {k, 1000u + static_cast<std::uint64_t>(d)};
          ref.deferred.clear();
          break;
        }
        default: {  // a scan (only after a settle, as select_indexed() does)
          std::map<std::int32_t, Time> keys;
          for (std::int32_t d : ref.deferred) keys[d] = key();
          o.settle([&](std::int32_t d) { return keys.at(d); }, [&](std::int32_t) { return std::uint64_t{7}; });
          for (const auto& [d, k] : keys) ref.live[d] = {k, 7};
          ref.deferred.clear();
          std::size_t seen = 0;  // current entries passed (visited) so far
          for (std::size_t k = 0; k < o.size();) {
            if (!o.current(k)) {
              o.erase(k);
              continue;
            }
            const auto want = ref.sorted();
            ASSERT_LT(seen, want.size());
            const BucketOrder::Entry e = o.at(k);
            ASSERT_EQ(std::make_tuple(e.key, e.bucket, e.stamp), want[seen]) << "seed " << seed << " step " << step;
            const unsigned action = rng() % 5;
            if (action == 0) {  // raised: moves later
              const Time k2 = e.key + 0.5 * (1 + rng() % 4);
              o.rekey(k, k2, ++stamp);
              ref.live[e.bucket] = {k2, stamp};
            } else if (action == 1) {  // dropped
              o.erase(k);
              ref.live.erase(e.bucket);
            } else if (action == 2) {  // the scan stops
              break;
            } else {  // visited: stays
              ++k;
              ++seen;
            }
          }
          break;
        }
      }
      // Between operations: the current entries, in order, are the reference's (deferred
      // buckets have none until settled).
      ASSERT_EQ(current_entries(o), ref.sorted()) << "seed " << seed << " step " << step;
    }
  }
}

// Superseded entries are dropped in bulk once they could be half the array, so a bucket
// deferred over and over does not grow it without bound.
TEST(BucketOrder, SupersededEntriesDoNotAccumulate) {
  BucketOrder o;
  o.reset(4);
  for (std::int32_t b = 0; b < 4; ++b) o.push(b, b, 0);
  for (int round = 0; round < 1000; ++round) {
    o.defer(round % 4);
    o.settle([](std::int32_t b) { return static_cast<Time>(b); }, [](std::int32_t) { return std::uint64_t{0}; });
  }
  EXPECT_LE(o.size(), 4u + 17u);
  std::vector<std::int32_t> order;
  for (std::size_t k = 0; k < o.size(); ++k)
    if (o.current(k)) order.push_back(o.at(k).bucket);
  EXPECT_EQ(order, (std::vector<std::int32_t>{0, 1, 2, 3}));
}

}  // namespace
}  // namespace rayline

// ActivityList (sched/timeline/activity_list.hpp) against std::vector as the reference: random
// sequences of the operations Schedule and the executors use, across the inline / heap
// boundary, with copies and moves in both directions.
#include <gtest/gtest.h>

#include <random>
#include <utility>
#include <vector>

#include "sched/timeline/activity_list.hpp"

namespace rayline {
namespace {

void expect_same(const ActivityList& a, const std::vector<ActivityId>& v) {
  ASSERT_EQ(a.size(), v.size());
  EXPECT_EQ(a.empty(), v.empty());
  EXPECT_GE(a.capacity(), a.size());
  EXPECT_EQ(a.on_heap(), a.capacity() > ActivityList::kInline);
  EXPECT_TRUE(std::equal(a.begin(), a.end(), v.begin(), v.end()));
  for (std::uint32_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i], v[i]);
}

TEST(ActivityList, ShortListsStayInline) {
  ActivityList a;
  EXPECT_FALSE(a.on_heap());
  a.reserve(ActivityList::kInline);
  for (ActivityId i = 0; i < ActivityList::kInline; ++i) a.push_back(10 + i);
  EXPECT_FALSE(a.on_heap());
  a.push_back(99);
  EXPECT_TRUE(a.on_heap());
  expect_same(a, {10, 11, 12, 99});
  // Moving a heap list hands the buffer over and leaves the source empty and inline.
  const ActivityId* buf = a.data();
  ActivityList b(std::move(a));
  EXPECT_EQ(b.data(), buf);
  EXPECT_TRUE(a.empty());  // NOLINT(bugprone-use-after-move): defined state checked
  EXPECT_FALSE(a.on_heap());
  ActivityList c = {7};
  c = b;  // copy onto an inline list
  expect_same(c, {10, 11, 12, 99});
  EXPECT_NE(c.data(), b.data());
  c = ActivityList{1, 2};  // move an inline list onto a heap one
  expect_same(c, {1, 2});
  EXPECT_FALSE(c.on_heap());
  EXPECT_TRUE(c == (ActivityList{1, 2}));
  EXPECT_FALSE(c == (ActivityList{1, 3}));
}

TEST(ActivityList, BehavesLikeAVectorUnderRandomOperations) {
  std::mt19937 rng(2026);
  for (int round = 0; round < 300; ++round) {
    std::vector<ActivityList> lists(4);
    std::vector<std::vector<ActivityId>> ref(4);
    for (int step = 0; step < 60; ++step) {
      const std::size_t i = rng() % 4, j = rng() % 4;
      switch (rng() % 8) {
        case 0:
        case 1: {
          const ActivityId id = static_cast<ActivityId>(rng() % 1000);
          lists[i].push_back(id);
          ref[i].push_back(id);
          break;
        }
        case 2: {
          std::vector<ActivityId> more(rng() % 6);
          for (ActivityId& x : more) x = static_cast<ActivityId>(rng() % 1000);
          lists[i].append(more.begin(), more.end());
          ref[i].insert(ref[i].end(), more.begin(), more.end());
          break;
        }
        case 3:
          lists[i] = lists[j];
          ref[i] = ref[j];
          break;
        case 4:
          if (i != j) {
            lists[i] = std::move(lists[j]);
            ref[i] = std::move(ref[j]);
            lists[j] = ActivityList{};
            ref[j].clear();
          }
          break;
        case 5:
          lists[i].reserve(rng() % 10);
          break;
        case 6: {  // an id it holds (often), or one it may not
          const ActivityId id = !ref[i].empty() && rng() % 4 != 0 ? ref[i][rng() % ref[i].size()]
                                                                 : static_cast<ActivityId>(rng() % 1000);
          lists[i].erase(id);
          std::erase(ref[i], id);
          break;
        }
        default: {
          ActivityList moved(std::move(lists[i]));
          lists[i] = moved;  // (a copy back, and `moved` goes out of scope)
          break;
        }
      }
      for (std::size_t k = 0; k < 4; ++k) expect_same(lists[k], ref[k]);
    }
  }
}

}  // namespace
}  // namespace rayline

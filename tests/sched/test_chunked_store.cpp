// ChunkedStore (sched/timeline/chunked_store.hpp): the Schedule's activities by id. Elements
// keep their address while the store grows, every element is destroyed once, a moved store
// hands its elements over and a copy holds its own.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "sched/timeline/chunked_store.hpp"

using rayline::ChunkedStore;

namespace {
struct Counted {
  static inline int alive = 0;
  std::string name;
  std::unique_ptr<int> value;
  explicit Counted(int v) : name("a" + std::to_string(v)), value(std::make_unique<int>(v)) { ++alive; }
  Counted(Counted&& o) noexcept : name(std::move(o.name)), value(std::move(o.value)) { ++alive; }
  ~Counted() { --alive; }
};
}  // namespace

TEST(ChunkedStore, ElementsStayWhereTheyAreAsItGrows) {
  {
    ChunkedStore<Counted, 4> s;  // chunks of 16
    std::vector<const Counted*> at;
    for (int i = 0; i < 1000; ++i) at.push_back(&s.push_back(Counted(i)));
    ASSERT_EQ(s.size(), 1000u);
    for (std::size_t i = 0; i < 1000; ++i) {
      EXPECT_EQ(&s[i], at[i]);
      EXPECT_EQ(*s[i].value, static_cast<int>(i));
      EXPECT_EQ(s[i].name, "a" + std::to_string(i));
    }
    EXPECT_EQ(Counted::alive, 1000);
    ChunkedStore<Counted, 4> t(std::move(s));
    EXPECT_EQ(s.size(), 0u);
    EXPECT_EQ(t.size(), 1000u);
    EXPECT_EQ(&t[999], at[999]);
    EXPECT_EQ(Counted::alive, 1000);
    s = std::move(t);
    EXPECT_EQ(*s[17].value, 17);
    s[17].value = std::make_unique<int>(-1);
    EXPECT_EQ(*s[17].value, -1);
  }
  EXPECT_EQ(Counted::alive, 0);
}

TEST(ChunkedStore, ACopyHoldsItsOwnElements) {
  ChunkedStore<std::string, 2> s;
  for (int i = 0; i < 11; ++i) s.push_back("x" + std::to_string(i));
  ChunkedStore<std::string, 2> t(s);
  t[3] = "changed";
  EXPECT_EQ(s[3], "x3");
  EXPECT_EQ(t.size(), 11u);
  EXPECT_EQ(t[10], "x10");
  s = t;
  EXPECT_EQ(s[3], "changed");
  EXPECT_NE(&s[3], &t[3]);
}

TEST(ChunkedStore, ClearDestroysEveryElement) {
  ChunkedStore<Counted, 2> s;
  for (int i = 0; i < 9; ++i) s.push_back(Counted(i));
  EXPECT_EQ(Counted::alive, 9);
  s.clear();
  EXPECT_EQ(Counted::alive, 0);
  EXPECT_TRUE(s.empty());
  s.push_back(Counted(5));
  EXPECT_EQ(*s[0].value, 5);
  s.clear();
  EXPECT_EQ(Counted::alive, 0);
}

// DataKind names (sched/core/data_block.hpp): the block kinds of Sec. 3.2 and 5.1 as they are
// written in platform and job files.
#include <gtest/gtest.h>

#include "sched/core/data_block.hpp"

namespace {

using namespace rayline;

TEST(DataKind, ParsesEveryNameAndRejectsOthers) {
  for (int i = 0; i < kDataKindCount; ++i) {
    DataKind k = DataKind::Generic;
    ASSERT_TRUE(parse_data_kind(kDataKindNames[static_cast<std::size_t>(i)], k));
    EXPECT_EQ(static_cast<int>(k), i);
    EXPECT_EQ(to_string(k), kDataKindNames[static_cast<std::size_t>(i)]);
  }
  DataKind k = DataKind::SceneData;
  EXPECT_FALSE(parse_data_kind("rayqueue", k));
  EXPECT_FALSE(parse_data_kind("", k));
  EXPECT_FALSE(parse_data_kind("RayQueue ", k));
  EXPECT_EQ(k, DataKind::SceneData);  // untouched on failure
}

}  // namespace

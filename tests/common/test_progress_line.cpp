// ProgressLine (common/progress_line.hpp): on a terminal one line rewritten in place, in a
// log whole "[what] ..." lines, nothing at all when off; never more often than its period.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>

#include "common/progress_line.hpp"

using rayline::ProgressLine;
using namespace std::chrono_literals;

namespace {
// How many lines a run of `total` with a check every 1 ms prints.
int lines_printed(ProgressLine& line, std::chrono::milliseconds total) {
  int n = 0;
  for (const auto end = std::chrono::steady_clock::now() + total; std::chrono::steady_clock::now() < end;) {
    if (line.due()) {
      line.print("test", "step %d", n);
      ++n;
    }
    std::this_thread::sleep_for(1ms);
  }
  return n;
}
}  // namespace

TEST(ProgressLine, ALogGetsWholePrefixedLinesNoOftenerThanItsPeriod) {
  ProgressLine line(ProgressLine::Mode::Log, 1ms, 40ms);
  EXPECT_FALSE(line.due());  // a short run prints nothing: the first line comes after a period
  ::testing::internal::CaptureStderr();
  const int n = lines_printed(line, 200ms);
  line.done();  // (a log line is complete: nothing to end)
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_GE(n, 1);
  EXPECT_LE(n, 5);  // 200 ms / 40 ms
  EXPECT_EQ(err.rfind("[test] step 0\n", 0), 0u) << err;
  EXPECT_EQ(err.find('\r'), std::string::npos) << err;
  EXPECT_EQ(static_cast<int>(std::count(err.begin(), err.end(), '\n')), n);
}

TEST(ProgressLine, ATerminalLineIsRewrittenInPlaceAndEndedOnce) {
  ProgressLine line(ProgressLine::Mode::Terminal, 10ms, 100000ms);
  ::testing::internal::CaptureStderr();
  const int n = lines_printed(line, 100ms);
  line.done();
  line.done();
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_GE(n, 2);
  EXPECT_EQ(static_cast<int>(std::count(err.begin(), err.end(), '\r')), n);
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;  // ended once, at done()
  EXPECT_EQ(err.back(), '\n');
  EXPECT_NE(err.find("\rstep 0"), std::string::npos) << err;  // no "[what]" prefix on a terminal
}

TEST(ProgressLine, OffPrintsNothingAndQuietIsOff) {
  ProgressLine line(ProgressLine::Mode::Off, 0ms, 0ms);
  ::testing::internal::CaptureStderr();
  EXPECT_FALSE(line.due());
  line.print("test", "never");
  line.done();
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(ProgressLine::for_stderr(true), ProgressLine::Mode::Off);
}

// Strict unit parsing (common/units.hpp): the quantities of platform and job files.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "common/units.hpp"

namespace {

using namespace rayline;
using namespace rayline::units;

TEST(Units, Sizes) {
  EXPECT_DOUBLE_EQ(parse_bytes("64B"), 64);
  EXPECT_DOUBLE_EQ(parse_bytes("210MB"), 210e6);
  EXPECT_DOUBLE_EQ(parse_bytes("8GiB"), 8.0 * 1024 * 1024 * 1024);
  EXPECT_DOUBLE_EQ(parse_bytes("512KiB"), 512.0 * 1024);
  EXPECT_DOUBLE_EQ(parse_bytes("1.5TB"), 1.5e12);
  EXPECT_DOUBLE_EQ(parse_bytes("2TiB"), 2.0 * 1099511627776.0);
  EXPECT_DOUBLE_EQ(parse_bytes("3kB"), 3000);
  EXPECT_DOUBLE_EQ(parse_bytes("0B"), 0);
  EXPECT_DOUBLE_EQ(parse_bytes("1e3B"), 1000);
}

TEST(Units, Bandwidths) {
  EXPECT_DOUBLE_EQ(parse_bandwidth("150MB/s"), 150e6);
  EXPECT_DOUBLE_EQ(parse_bandwidth("1Gb/s"), 125e6);     // 1 GbE = 125 MB/s
  EXPECT_DOUBLE_EQ(parse_bandwidth("100Mb/s"), 12.5e6);  // 100 Mb Ethernet
  EXPECT_DOUBLE_EQ(parse_bandwidth("12GB/s"), 12e9);
  EXPECT_DOUBLE_EQ(parse_bandwidth("12.5MB/s"), 12.5e6);
  EXPECT_DOUBLE_EQ(parse_bandwidth("1GiB/s"), 1073741824.0);
  EXPECT_DOUBLE_EQ(parse_bandwidth("8b/s"), 1);
}

TEST(Units, Durations) {
  EXPECT_DOUBLE_EQ(parse_duration("8ms"), 8e-3);
  EXPECT_DOUBLE_EQ(parse_duration("100us"), 100e-6);
  EXPECT_DOUBLE_EQ(parse_duration("2s"), 2);
  EXPECT_DOUBLE_EQ(parse_duration("50ns"), 50e-9);
  EXPECT_DOUBLE_EQ(parse_duration("1.5min"), 90);
  EXPECT_DOUBLE_EQ(parse_duration("0s"), 0);
}

TEST(Units, Rates) {
  EXPECT_DOUBLE_EQ(parse_rate("10M/s"), 10e6);
  EXPECT_DOUBLE_EQ(parse_rate("500k/s"), 500e3);
  EXPECT_DOUBLE_EQ(parse_rate("7/s"), 7);
}

// Every malformed input throws std::invalid_argument whose message quotes the input and
// says what form was expected.
void expect_reject(double (*parse)(std::string_view), const std::string& text) {
  try {
    parse(text);
    ADD_FAILURE() << "accepted '" << text << "'";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("expected"), std::string::npos) << msg;
    EXPECT_NE(msg.find("'" + text + "'"), std::string::npos) << msg;
  }
}

TEST(Units, RejectsMalformedSizes) {
  for (const char* s : {"", "8", "GiB", "8 GiB", " 8GiB", "8GiB ", "8GiBx", "8XB", "-1B", "nanB", "infB", "NaN",
                        "1.2.3MB", "8Gb", "8gib", "1,5MB", "8M", "+-1B", "8 B"})
    expect_reject(parse_bytes, s);
}

TEST(Units, RejectsMalformedBandwidths) {
  for (const char* s : {"", "150", "150MB", "150 MB/s", "150MB/s/s", "150MB/sec", "0MB/s", "0Gb/s", "-1MB/s",
                        "nanMB/s", "inf MB/s", "150XB/s", "MB/s", "1e999MB/s", "150MB/ s", "1 5MB/s"})
    expect_reject(parse_bandwidth, s);
}

TEST(Units, RejectsMalformedDurations) {
  for (const char* s : {"", "8", "ms", "8 ms", "-1s", "8msx", "8sec", "nans", "8m", "1..5s"})
    expect_reject(parse_duration, s);
}

// Values no device has, whose derived times overflow (a 1e-300 B/s rate printed a
// 300-digit makespan and NaN utilisations): rejected, the bounds themselves accepted.
TEST(Units, RejectsQuantitiesWhoseTimesWouldOverflow) {
  for (const char* s : {"1e-300B/s", "1e-320B/s", "0.5B/s", "7b/s"}) expect_reject(parse_bandwidth, s);
  for (const char* s : {"1e300GB", "1153000TB", "1048577TiB"}) expect_reject(parse_bytes, s);
  for (const char* s : {"1e300s", "1e10s", "300000h"}) expect_reject(parse_duration, s);
  EXPECT_DOUBLE_EQ(parse_bandwidth("1B/s"), 1.0);
  EXPECT_DOUBLE_EQ(parse_bandwidth("8b/s"), 1.0);
  EXPECT_DOUBLE_EQ(parse_bytes("1048576TiB"), 1152921504606846976.0);
  EXPECT_DOUBLE_EQ(parse_duration("1e9s"), 1e9);
  EXPECT_DOUBLE_EQ(parse_duration("1e-300s"), 1e-300);
}

TEST(Units, RejectsMalformedRates) {
  for (const char* s : {"", "10M", "10Mx/s", "0/s", "-5/s", "10 M/s"}) expect_reject(parse_rate, s);
}

}  // namespace

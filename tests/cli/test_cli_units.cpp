// The command line's quantities (apps/cli_common.hpp): durations and sizes take a unit,
// and a bad one is an InputError naming the flag, the value and the accepted units; the
// summary lines' numbers print with three significant digits and a unit.
#include <gtest/gtest.h>

#include <string>

#include "apps/cli_common.hpp"
#include "common/error.hpp"

using rayline::InputError;
using namespace rayline::cli;

namespace {

// The message of the InputError that `parse` throws, or "" when it throws none.
template <class Parse>
std::string error_of(Parse parse) {
  try {
    parse();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(CliDurations, TakeEveryUnit) {
  EXPECT_DOUBLE_EQ(duration_flag("--horizon", "2s"), 2);
  EXPECT_DOUBLE_EQ(duration_flag("--horizon", "500ms"), 0.5);
  EXPECT_DOUBLE_EQ(duration_flag("--horizon", "1.5min"), 90);
  EXPECT_DOUBLE_EQ(duration_flag("--horizon", "2h"), 7200);
  EXPECT_DOUBLE_EQ(duration_flag("--horizon", "100us"), 100e-6);
  EXPECT_DOUBLE_EQ(duration_flag("--horizon", "50ns"), 50e-9);
  EXPECT_DOUBLE_EQ(duration_flag("--horizon", "0s"), 0);
}

TEST(CliDurations, BareNumberNamesFlagValueAndUnits) {
  for (const char* bare : {"2", "0.5", "1e3", "-1"}) {
    const std::string e = error_of([&] { duration_flag("--duration", bare); });
    EXPECT_TRUE(has(e, "--duration: '" + std::string(bare) + "' has no unit")) << e;
    EXPECT_TRUE(has(e, "ns, us, ms, s, min, h")) << e;
  }
}

TEST(CliDurations, RejectNegativeOverflowAndUnknownUnits) {
  for (const char* bad : {"-1s", "1e10s", "2x", "2 s", "s", "", "nans", "infs", "2sec"}) {
    const std::string e = error_of([&] { duration_flag("--warmup", bad); });
    EXPECT_TRUE(has(e, "--warmup: ")) << bad << ": " << e;
    EXPECT_TRUE(has(e, "units: ns, us, ms, s, min, h")) << bad << ": " << e;
  }
  EXPECT_TRUE(has(error_of([] { duration_flag("--warmup", "-1s"); }), "negative"));
  EXPECT_TRUE(has(error_of([] { duration_flag("--warmup", "1e10s"); }), "longer than 1e9 s"));
}

TEST(CliSizes, TakeDecimalAndBinaryPrefixes) {
  EXPECT_EQ(size_flag("--memory-budget", "64GiB"), 64ull << 30);
  EXPECT_EQ(size_flag("--memory-budget", "512MiB"), 512ull << 20);
  EXPECT_EQ(size_flag("--memory-budget", "1.5GB"), 1500000000ull);
  EXPECT_EQ(size_flag("--memory-budget", "4096B"), 4096ull);
  EXPECT_EQ(size_flag("--memory-budget", "3kB"), 3000ull);
  EXPECT_EQ(size_flag("--memory-budget", "2TiB"), 2ull << 40);
  EXPECT_EQ(size_flag("--memory-budget", "1.6B"), 2ull) << "rounded to whole bytes";
}

TEST(CliSizes, BareNumberNamesFlagValueAndUnits) {
  for (const char* bare : {"64", "1048576", "1.5", "-3"}) {
    const std::string e = error_of([&] { size_flag("--memory-limit", bare); });
    EXPECT_TRUE(has(e, "--memory-limit: '" + std::string(bare) + "' has no unit")) << e;
    EXPECT_TRUE(has(e, "B, kB, MB, GB, TB, KiB, MiB, GiB, TiB")) << e;
  }
}

TEST(CliSizes, RejectBitsZeroNegativeAndOverflow) {
  for (const char* bad : {"8Gb", "0B", "0.2B", "-1GiB", "2000000TiB", "1e300GB", "64M", "64G", "1XB", ""}) {
    const std::string e = error_of([&] { size_flag("--gpu-memory-budget", bad); });
    EXPECT_TRUE(has(e, "--gpu-memory-budget: ")) << bad << ": " << e;
    EXPECT_TRUE(has(e, "'" + std::string(bad) + "'")) << bad << ": " << e;
  }
  EXPECT_TRUE(has(error_of([] { size_flag("--memory-budget", "2000000TiB"); }), "larger than 1 EiB"));
  EXPECT_TRUE(has(error_of([] { size_flag("--memory-budget", "8Gb"); }), "bytes"));
}

TEST(CliFormat, DurationsKeepThreeDigitsAndAUnit) {
  EXPECT_EQ(format_duration(12.34), "12.3 s");
  EXPECT_EQ(format_duration(1.5), "1.50 s");
  EXPECT_EQ(format_duration(123.4), "123 s");
  EXPECT_EQ(format_duration(1234.4), "1234 s");
  EXPECT_EQ(format_duration(0.0042), "4.20 ms");
  EXPECT_EQ(format_duration(42e-6), "42.0 us");
  EXPECT_EQ(format_duration(7e-9), "7.00 ns");
  EXPECT_EQ(format_duration(0.99996), "1.00 s") << "rounding up crosses into the next unit";
  EXPECT_EQ(format_duration(0), "0 s");
}

TEST(CliFormat, SizesUseBinaryPrefixes) {
  EXPECT_EQ(format_size(1.5 * (1ull << 30)), "1.50 GiB");
  EXPECT_EQ(format_size(512.0 * (1 << 20)), "512 MiB");
  EXPECT_EQ(format_size(64), "64 B");
  EXPECT_EQ(format_size(0), "0 B");
  EXPECT_EQ(format_size(1023.9), "1.00 KiB");
  EXPECT_EQ(format_size(3.0 * (1ull << 40)), "3.00 TiB");
  EXPECT_EQ(format_size(5000.0 * (1ull << 40)), "5000 TiB");
}

TEST(CliFormat, RatesUseDecimalPrefixes) {
  EXPECT_EQ(format_rate(4.273e6, "rays"), "4.27 M rays/s");
  EXPECT_EQ(format_rate(290000, "rays"), "290 k rays/s");
  EXPECT_EQ(format_rate(1e9, "triangles"), "1.00 G triangles/s");
  EXPECT_EQ(format_rate(999960, "rays"), "1.00 M rays/s");
  EXPECT_EQ(format_rate(12.5, "rays"), "12.5 rays/s");
  EXPECT_EQ(format_rate(0, "rays"), "0 rays/s");
}

TEST(CliFormat, BandwidthsUseDecimalPrefixes) {
  EXPECT_EQ(format_bandwidth(1.5e8), "150 MB/s");
  EXPECT_EQ(format_bandwidth(1.25e9), "1.25 GB/s");
  EXPECT_EQ(format_bandwidth(512), "512 B/s");
}

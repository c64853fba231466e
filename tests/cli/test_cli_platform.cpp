// `rayline platform check`: runs the real binary (RAYLINE_BINARY). Exit codes: 0 ok,
// 2 bad input with "FILE: FIELD: message" on stderr (docs/architecture.md, "Bad input").
#include <gtest/gtest.h>

#include "cli_run.hpp"
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace {

using CliRun = rayline::testing::CliResult;
CliRun rayline(const std::string& args) { return rayline::testing::rayline_cli(args); }

const std::string kPlatforms = RAYLINE_PLATFORMS;
const std::string kBad = std::string(RAYLINE_TEST_DATA) + "/platforms/bad/";

TEST(CliPlatform, CheckPaperCluster) {
  const CliRun r = rayline("platform check '" + kPlatforms + "/paper-cluster.json'");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("84"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("24"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("paper-cluster"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("A0.gpu0mem"), std::string::npos) << r.out;
}

TEST(CliPlatform, CheckJson) {
  const CliRun r = rayline("platform check '" + kPlatforms + "/paper-cluster.json' --json --block-size 210MB");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["nodes"], 8);
  EXPECT_EQ(j["compute_devices"]["total"], 84);
  EXPECT_EQ(j["compute_devices"]["by_kind"]["gpu"], 8);
  EXPECT_EQ(j["memory_devices"]["total"], 24);
  EXPECT_EQ(j["block_bytes"], 210000000);
  EXPECT_NEAR(j["shortest_fetch_s"]["A0.ram"].get<double>(), 1.41, 1e-9);  // 10 ms + 210 MB / 150 MB/s
  EXPECT_EQ(j["shortest_fetch_s"]["A0.disk"].get<double>(), 0.0);
}

TEST(CliPlatform, BuiltInNameResolves) {
  const CliRun r = rayline("platform check paper-A");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("paper-A"), std::string::npos);
}

TEST(CliPlatform, BadFixturesExit2WithFileAndField) {
  struct Case {
    const char* file;
    const char* field;
  };
  for (const Case& c : {Case{"invalid_json.json", "line"}, Case{"unknown_memory.json", "node_types.A.compute[1].memory"},
                        Case{"bad_bandwidth.json", "node_types.A.channels[1].bandwidth"},
                        Case{"unreachable_gpu.json", "node_types.A.memory[2]"},
                        Case{"unknown_key.json", "networks[0].members[0].bandwith"}}) {
    SCOPED_TRACE(c.file);
    const CliRun r = rayline("platform check '" + kBad + c.file + "'");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find(c.file), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.field), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;  // nothing half-printed on stdout
  }
}

TEST(CliPlatform, MissingFileExits2) {
  const CliRun r = rayline("platform check /nonexistent/dir/platform.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("/nonexistent/dir/platform.json"), std::string::npos) << r.err;
}

TEST(CliPlatform, BadBlockSizeExits2) {
  const CliRun r = rayline("platform check '" + kPlatforms + "/paper-A.json' --block-size 12parsecs");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--block-size"), std::string::npos) << r.err;
}

TEST(CliPlatform, Help) {
  EXPECT_EQ(rayline("platform check --help").code, 0);
  EXPECT_EQ(rayline("platform --help").code, 0);
  EXPECT_EQ(rayline("--help").code, 0);
}

}  // namespace

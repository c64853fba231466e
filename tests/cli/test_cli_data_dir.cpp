// Where the rayline binary finds built-in platforms and scene profiles (apps/data_dir.hpp):
// $RAYLINE_PLATFORMS / $RAYLINE_SCENES alone when set, else <bin>/../share/rayline, else the
// source tree; a name found nowhere exits 2 naming every folder searched.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <sys/wait.h>

#include "cli_run.hpp"
#include "scratch_test.hpp"

namespace {

namespace fs = std::filesystem;
using rayline::testing::rayline_cli;

const std::string kPlatforms = RAYLINE_PLATFORMS;
const std::string kScenes = RAYLINE_SCENES_DIR;

class CliDataDir : public rayline::testing::ScratchTest {
 protected:
  void TearDown() override {
    ::unsetenv("RAYLINE_PLATFORMS");
    ::unsetenv("RAYLINE_SCENES");
    ScratchTest::TearDown();
  }
};

TEST_F(CliDataDir, UnknownPlatformNameListsEveryFolderSearched) {
  const auto r = rayline_cli("platform check paper-Z");
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("rayline: --platform: 'paper-Z' is neither a file nor a built-in name"), std::string::npos) << r.err;
  const std::string beside = (fs::path(RAYLINE_BINARY).parent_path() / "../share/rayline/platforms").lexically_normal();
  const auto at_beside = r.err.find(beside), at_source = r.err.find(kPlatforms);
  ASSERT_NE(at_beside, std::string::npos) << r.err;
  ASSERT_NE(at_source, std::string::npos) << r.err;
  EXPECT_LT(at_beside, at_source) << "the folder beside the binary comes first: " << r.err;
}

TEST_F(CliDataDir, BuiltInNamesComeFromTheSourceTreeInTheBuildTree) {
  const auto r = rayline_cli("platform check paper-A");
  EXPECT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("paper-A"), std::string::npos) << r.out;
}

TEST_F(CliDataDir, RaylinePlatformsReplacesTheSearch) {
  fs::copy_file(kPlatforms + "/paper-A.json", path("mine.json"));
  ::setenv("RAYLINE_PLATFORMS", dir_.c_str(), 1);
  EXPECT_EQ(rayline_cli("platform check mine").code, 0);
  const auto r = rayline_cli("platform check paper-2A");  // not in $RAYLINE_PLATFORMS
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("no paper-2A.json in " + dir_.string() + " (set $RAYLINE_PLATFORMS"), std::string::npos) << r.err;
}

TEST_F(CliDataDir, RaylineScenesHoldsTheSceneProfiles) {
  fs::copy_file(kScenes + "/museum.profile.json", path("museum.profile.json"));
  ::setenv("RAYLINE_SCENES", dir_.c_str(), 1);
  const auto r = rayline_cli("simulate --workload museum --duration 1s --no-progress --out " + path("out"));
  ASSERT_EQ(r.code, 0) << r.all;
  const auto m = nlohmann::json::parse(std::ifstream(path("out/metrics.json")));
  EXPECT_EQ(m["workload"], path("museum.profile.json"));
  const auto missing = rayline_cli("simulate --workload boeing --duration 1s --no-progress --out " + path("out2"));
  EXPECT_EQ(missing.code, 2) << missing.all;
  EXPECT_NE(missing.err.find("rayline: --workload: 'boeing' is neither a file nor a built-in name: no boeing.profile.json in " +
                             dir_.string()),
            std::string::npos)
      << missing.err;
  EXPECT_FALSE(fs::exists(path("out2")));
}

// A copy of the binary in PREFIX/bin reads PREFIX/share/rayline/platforms, which holds a
// platform the source tree does not.
TEST_F(CliDataDir, ABinaryReadsTheShareFolderBesideIt) {
  fs::create_directories(path("bin"));
  fs::create_directories(path("share/rayline/platforms"));
  fs::copy_file(RAYLINE_BINARY, path("bin/rayline"));
  fs::copy_file(kPlatforms + "/paper-A.json", path("share/rayline/platforms/only-here.json"));
  FILE* p = ::popen((path("bin/rayline") + " platform check only-here 2>&1").c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  const int status = ::pclose(p);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << out;
  EXPECT_NE(out.find("paper-A"), std::string::npos) << out;
}

}  // namespace

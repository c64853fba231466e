// An interrupted run leaves nothing behind (apps/interrupt.hpp): SIGTERM, SIGINT or SIGHUP
// used to end `rayline` at once, leaving OUT.partial.<pid>/, a render's temporary partition
// in /tmp (154 MB for a 2 M-triangle scene) or a half-written mesh of FILE.tmp.<pid>.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli/scratch_test.hpp"

namespace fs = std::filesystem;

namespace {
class Interrupt : public rayline::testing::ScratchTest {
 protected:
  void TearDown() override {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    ScratchTest::TearDown();
  }

  // Starts `rayline ARGS...` (stdout and stderr to files in the scratch folder).
  void start(const std::vector<std::string>& args) {
    pid_ = ::fork();
    ASSERT_GE(pid_, 0);
    if (pid_ == 0) {
      ::signal(SIGINT, SIG_DFL);  // whatever the test runner ignores, rayline starts as from a terminal
      ::signal(SIGHUP, SIG_DFL);
      ::signal(SIGTERM, SIG_DFL);
      std::vector<char*> argv{const_cast<char*>(RAYLINE_BINARY)};
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      if (!std::freopen(path("stdout").c_str(), "w", stdout) || !std::freopen(path("stderr").c_str(), "w", stderr))
        ::_exit(99);
      ::execv(RAYLINE_BINARY, argv.data());
      ::_exit(98);
    }
  }
  // Polls (up to 120 s, for a slow machine) until `ready` holds; false if rayline ended first.
  bool wait_until(const std::function<bool()>& ready) {
    for (int i = 0; i < 12000; ++i) {
      if (ready()) return true;
      int st = 0;
      if (::waitpid(pid_, &st, WNOHANG) == pid_) {
        pid_ = -1;
        return false;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  // Waits for the run to end on its own; its exit code.
  int finish() {
    int st = 0;
    ::waitpid(pid_, &st, 0);
    pid_ = -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  }
  // Sends `sig` and returns the exit code (-1: killed by a signal, that is, not handled).
  int stop(int sig) {
    ::kill(pid_, sig);
    int st = 0;
    ::waitpid(pid_, &st, 0);
    pid_ = -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  }
  std::string err() const {
    std::ifstream in(path("stderr"));
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  static bool any_starting(const fs::path& dir, const std::string& prefix) {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec))
      if (e.path().filename().string().starts_with(prefix)) return true;
    return false;
  }
  // A render's temporary partition of process `pid`: /tmp/rayline-blocks-<ns>.partial.<pid>@<host>.
  static bool any_partition_of(pid_t pid) {
    std::error_code ec;
    const std::string tag = ".partial." + std::to_string(pid) + "@";
    for (const auto& e : fs::directory_iterator(fs::temp_directory_path(), ec)) {
      const std::string name = e.path().filename().string();
      if (name.starts_with("rayline-blocks-") && name.find(tag) != std::string::npos) return true;
    }
    return false;
  }
  pid_t pid_ = -1;
};
}  // namespace

TEST_F(Interrupt, SimulateRemovesItsPartialFolderAndKeepsTheEarlierResults) {
  start({"simulate", "--platform", "paper-A", "--duration", "1s", "--no-progress", "--out", path("run")});
  ASSERT_EQ(finish(), 0) << err();  // the first run completes
  ASSERT_TRUE(fs::exists(path("run/metrics.json")));
  start({"simulate", "--duration", "1000000s", "--no-timeline", "--no-progress", "--out", path("run")});
  ASSERT_TRUE(wait_until([&] { return any_starting(dir_, "run.partial."); })) << err();
  EXPECT_EQ(stop(SIGTERM), 128 + SIGTERM) << err();
  EXPECT_NE(err().find("interrupted"), std::string::npos) << err();
  EXPECT_FALSE(any_starting(dir_, "run.")) << "no partial or old folder left";
  EXPECT_TRUE(fs::exists(path("run/metrics.json"))) << "the earlier results are untouched";
}

TEST_F(Interrupt, CompareStopsItsRunAndBothRemoveTheirOutputs) {
  start({"compare", "--duration", "1000000s", "--schedulers", "gmb,budge", "--out", path("cmp")});
  ASSERT_TRUE(wait_until([&] { return any_starting(dir_ / "cmp", "gmb.partial."); })) << err();
  EXPECT_EQ(stop(SIGINT), 128 + SIGINT) << err();
  // The parent waited for its child, which removed its partial folder before ending.
  EXPECT_FALSE(any_starting(dir_ / "cmp", "gmb")) << err();
}

TEST_F(Interrupt, RenderRemovesItsTemporaryPartition) {
  start({"render", "-q", "--spp", "100000", "--resolution", "64x64", "--out", path("r.exr")});
  const pid_t pid = pid_;
  const auto mine = [pid] { return any_partition_of(pid); };
  ASSERT_TRUE(wait_until(mine)) << err();
  EXPECT_EQ(stop(SIGHUP), 128 + SIGHUP) << err();
  EXPECT_FALSE(mine());
  EXPECT_FALSE(any_starting(dir_, "r.")) << "no image, no partial image";
}

TEST_F(Interrupt, GenerateRemovesItsHalfWrittenMesh) {
  start({"generate", "museum-like", "-q", "-n", "1G", "--out", path("big.ply")});
  ASSERT_TRUE(wait_until([&] { return any_starting(dir_, "big.ply.tmp."); })) << err();
  EXPECT_EQ(stop(SIGTERM), 128 + SIGTERM) << err();
  EXPECT_FALSE(any_starting(dir_, "big.")) << err();
}

// SIGKILL (or the OOM killer, a crash) gives no handler a chance: the killed run's partial
// folder stays, and the next run into the same --out removes it (common/unfinished_output.hpp).
TEST_F(Interrupt, AKilledRunsPartialFolderIsRemovedByTheNextRun) {
  start({"simulate", "--duration", "1000000s", "--no-timeline", "--no-progress", "--out", path("run")});
  ASSERT_TRUE(wait_until([&] { return any_starting(dir_, "run.partial."); })) << err();
  EXPECT_EQ(stop(SIGKILL), -1);
  ASSERT_TRUE(any_starting(dir_, "run.partial.")) << "nothing could remove it";
  start({"simulate", "--platform", "paper-A", "--duration", "1s", "--no-progress", "--out", path("run")});
  ASSERT_EQ(finish(), 0) << err();
  EXPECT_NE(err().find("left by a run that ended before it finished"), std::string::npos) << err();
  EXPECT_FALSE(any_starting(dir_, "run.")) << "no partial folder left";
  EXPECT_TRUE(fs::exists(path("run/metrics.json")));
}

TEST_F(Interrupt, AKilledRunsHalfWrittenMeshIsRemovedByTheNextRun) {
  start({"generate", "museum-like", "-q", "-n", "1G", "--out", path("big.ply")});
  ASSERT_TRUE(wait_until([&] { return any_starting(dir_, "big.ply.tmp-faces."); })) << err();
  EXPECT_EQ(stop(SIGKILL), -1);
  ASSERT_TRUE(any_starting(dir_, "big.ply.tmp")) << "nothing could remove it";
  start({"generate", "museum-like", "-q", "-n", "10000", "--out", path("big.ply")});
  ASSERT_EQ(finish(), 0) << err();
  EXPECT_FALSE(any_starting(dir_, "big.ply.")) << err();
  EXPECT_TRUE(fs::exists(path("big.ply")));
}

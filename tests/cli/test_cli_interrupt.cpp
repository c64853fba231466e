// An interrupted run leaves nothing behind (apps/interrupt.hpp): SIGTERM, SIGINT or SIGHUP
// used to end `rayline` at once, leaving OUT.partial.<pid>/, a render's temporary partition
// in /tmp (154 MB for a 2 M-triangle scene) or a half-written mesh of FILE.tmp.<pid>.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
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
  // The runs write into compare's staging folder, cmp.partial.<pid>@<host>/<scheduler>.
  const auto running = [&] {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec))
      if (e.path().filename().string().starts_with("cmp.partial.") && any_starting(e.path(), "gmb.partial.")) return true;
    return false;
  };
  ASSERT_TRUE(wait_until(running)) << err();
  EXPECT_EQ(stop(SIGINT), 128 + SIGINT) << err();
  // The parent waited for its child, which removed its partial folder before ending, and
  // then removed its own.
  EXPECT_FALSE(any_starting(dir_, "cmp")) << err();
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
  start({"generate", "museum-like", "-q", "--triangles", "1G", "--out", path("big.ply")});
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
  start({"generate", "museum-like", "-q", "--triangles", "1G", "--out", path("big.ply")});
  ASSERT_TRUE(wait_until([&] { return any_starting(dir_, "big.ply.tmp-faces."); })) << err();
  EXPECT_EQ(stop(SIGKILL), -1);
  ASSERT_TRUE(any_starting(dir_, "big.ply.tmp")) << "nothing could remove it";
  start({"generate", "museum-like", "-q", "--triangles", "10000", "--out", path("big.ply")});
  ASSERT_EQ(finish(), 0) << err();
  EXPECT_FALSE(any_starting(dir_, "big.ply.")) << err();
  EXPECT_TRUE(fs::exists(path("big.ply")));
}

// The processes of a `compare` or a client sweep never outlive it, and their results appear
// all together or not at all: a survivor of a killed `compare` went on for a minute and
// then published its results under --out (apps/run/child_process.hpp,
// apps/run/staged_folder.hpp). The test is a subreaper, so the runs of a killed rayline
// become its children: it can see whether they are still alive and reap them.
namespace {
class ResultSets : public Interrupt {
 protected:
  void SetUp() override {
    Interrupt::SetUp();
    ASSERT_EQ(::prctl(PR_SET_CHILD_SUBREAPER, 1), 0);
  }
  void TearDown() override {
    for (pid_t c : runs_) {
      ::kill(c, SIGKILL);
      ::waitpid(c, nullptr, 0);
    }
    Interrupt::TearDown();
  }
  // The processes whose parent is `parent` (from /proc/<pid>/stat: "pid (comm) state ppid").
  static std::vector<pid_t> children_of(pid_t parent) {
    std::vector<pid_t> out;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator("/proc", ec)) {
      const std::string name = e.path().filename().string();
      if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
      std::ifstream in(e.path() / "stat");
      std::string stat;
      std::getline(in, stat);
      const std::size_t close = stat.rfind(')');
      if (close == std::string::npos) continue;
      std::istringstream rest(stat.substr(close + 1));
      char state = 0;
      long ppid = 0;
      if (rest >> state >> ppid && ppid == parent) out.push_back(static_cast<pid_t>(std::stol(name)));
    }
    return out;
  }
  // Starts `args`, waits until it runs a child process, and remembers the children.
  void start_runs(const std::vector<std::string>& args) {
    start(args);
    const pid_t parent = pid_;
    ASSERT_TRUE(wait_until([&] { return !children_of(parent).empty(); })) << err();
    runs_ = children_of(parent);
  }
  // True once every remembered run has ended (reaped here, as their subreaper).
  bool runs_ended(std::chrono::milliseconds within) {
    const auto until = std::chrono::steady_clock::now() + within;
    for (;;) {
      std::vector<pid_t> alive;
      for (pid_t c : runs_) {
        const pid_t w = ::waitpid(c, nullptr, WNOHANG);
        if (w == 0 || (w < 0 && errno != ECHILD)) alive.push_back(c);
      }
      runs_ = alive;
      if (runs_.empty()) return true;
      if (std::chrono::steady_clock::now() > until) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  std::vector<pid_t> runs_;
};

// A run that takes about 2 s here: a survivor would publish well within the test.
const std::vector<std::string> kCompare = {"compare", "--duration", "2000s", "--schedulers", "gmb,budge"};
const std::vector<std::string> kSweep = {"simulate", "--workload", "museum", "--platform", "paper-A", "--duration",
                                         "800s",     "--clients",  "1,2",    "--no-progress", "--no-timeline"};
std::vector<std::string> with_out(std::vector<std::string> args, const std::string& out) {
  args.push_back("--out");
  args.push_back(out);
  return args;
}
}  // namespace

TEST_F(ResultSets, AKilledCompareTakesItsRunsWithItAndPublishesNothing) {
  start_runs(with_out(kCompare, path("cmp")));
  EXPECT_EQ(stop(SIGKILL), -1);
  EXPECT_TRUE(runs_ended(std::chrono::seconds(3))) << runs_.size() << " run(s) of the killed compare still alive";
  std::this_thread::sleep_for(std::chrono::seconds(6));
  EXPECT_FALSE(fs::exists(path("cmp"))) << "results published after the compare was killed";
  // What the killed compare staged is removed by the next run into the same place.
  start({"compare", "--platform", "paper-A", "--duration", "1s", "--schedulers", "gmb", "--out", path("cmp")});
  ASSERT_EQ(finish(), 0) << err();
  EXPECT_TRUE(fs::exists(path("cmp/gmb/metrics.json")));
  EXPECT_FALSE(any_starting(dir_, "cmp.")) << err();
}

TEST_F(ResultSets, AStoppedCompareStopsItsRunsAndLeavesNothing) {
  start_runs(with_out(kCompare, path("cmp")));
  EXPECT_EQ(stop(SIGTERM), 128 + SIGTERM) << err();
  EXPECT_TRUE(runs_ended(std::chrono::seconds(3))) << runs_.size() << " run(s) of the stopped compare still alive";
  std::this_thread::sleep_for(std::chrono::seconds(4));
  EXPECT_FALSE(any_starting(dir_, "cmp")) << "results or a staging folder left after the compare was stopped";
}

TEST_F(ResultSets, AKilledSweepTakesItsRunsWithItAndPublishesNothing) {
  start_runs(with_out(kSweep, path("sweep")));
  EXPECT_EQ(stop(SIGKILL), -1);
  EXPECT_TRUE(runs_ended(std::chrono::seconds(3))) << runs_.size() << " point(s) of the killed sweep still alive";
  std::this_thread::sleep_for(std::chrono::seconds(6));
  EXPECT_FALSE(fs::exists(path("sweep"))) << "results published after the sweep was killed";
}

TEST_F(ResultSets, AStoppedSweepStopsItsRunsAndLeavesNothing) {
  start_runs(with_out(kSweep, path("sweep")));
  EXPECT_EQ(stop(SIGTERM), 128 + SIGTERM) << err();
  EXPECT_TRUE(runs_ended(std::chrono::seconds(3))) << runs_.size() << " point(s) of the stopped sweep still alive";
  std::this_thread::sleep_for(std::chrono::seconds(4));
  EXPECT_FALSE(any_starting(dir_, "sweep")) << "results or a staging folder left after the sweep was stopped";
}

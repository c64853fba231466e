// sched/unfinished_output: what a run killed without a chance to clean up (SIGKILL, a crash)
// left beside its output is removed by the next run writing that output, and nothing of a
// live run, another host's run or another output is touched.
#include "common/unfinished_output.hpp"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
namespace uf = rayline::unfinished;

namespace {
fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("rayline-uf-" + std::to_string(::getpid()) + "-" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

// A pid that has just ended (a child reaped at once). Pids are reused only after the
// kernel's pid space wraps, far beyond one test.
pid_t ended_pid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  ::waitpid(pid, nullptr, 0);
  return pid;
}

std::string host_of(const std::string& tag) { return tag.substr(tag.find('@')); }

void touch(const fs::path& p, const std::string& text = "x") { std::ofstream(p) << text; }
}  // namespace

TEST(Unfinished, TempNameCarriesThisProcessAndHost) {
  const std::string tag = uf::owner_tag();
  EXPECT_EQ(tag.substr(0, tag.find('@')), std::to_string(::getpid()));
  EXPECT_GT(tag.size(), tag.find('@') + 1) << "a host name";
  EXPECT_EQ(tag.find_first_of("/ \t\n"), std::string::npos);
  EXPECT_EQ(uf::temp_name("/a/out", "partial"), "/a/out.partial." + tag);
}

TEST(Unfinished, OnlyAnEndedProcessOfThisHostIsGone) {
  const std::string host = host_of(uf::owner_tag());
  EXPECT_TRUE(uf::owner_gone(std::to_string(ended_pid()) + host));
  EXPECT_FALSE(uf::owner_gone(uf::owner_tag())) << "this process";
  EXPECT_FALSE(uf::owner_gone(std::to_string(::getppid()) + host)) << "a live process";
  EXPECT_FALSE(uf::owner_gone(std::to_string(ended_pid()) + host + "x")) << "another host";
  EXPECT_FALSE(uf::owner_gone(std::to_string(ended_pid()) + "@")) << "no host";
  for (const std::string& bad : std::vector<std::string>{std::string(), host, "12", "1a" + host, "-5" + host, "0" + host, "1" + host,
                                 "9999999999" + host, std::to_string(ended_pid())})
    EXPECT_FALSE(uf::owner_gone(bad)) << "malformed, pid 0/1 or no host: '" << bad << "'";
}

TEST(Unfinished, SweepRemovesWhatEndedRunsLeftOfThisOutputOnly) {
  const fs::path d = scratch("sweep");
  const std::string host = host_of(uf::owner_tag());
  const std::string dead = std::to_string(ended_pid()) + host;
  const std::string target = (d / "out").string();
  fs::create_directory(target);
  touch(d / "out" / "metrics.json", "earlier results");
  const fs::path partial = target + ".partial." + dead;  // a killed simulate's folder
  fs::create_directory(partial);
  touch(partial / "jobs.csv");
  touch(target + ".tmp." + dead);                                        // a killed file write
  touch(target + ".tmp-faces." + dead);                                  // a killed mesh writer's faces
  const fs::path live = target + ".partial." + uf::owner_tag();          // a live run (this one)
  const fs::path other_host = target + ".partial." + std::to_string(ended_pid()) + "@elsewhere";
  const fs::path other_output = d / ("out2.partial." + dead);            // another output's leftover
  const fs::path not_ours = d / ("out.partial.notes");                   // the user's own file
  const fs::path other_kind = target + ".backup." + dead;                // not a kind rayline writes
  for (const fs::path& p : {live, other_host, other_output, not_ours, other_kind}) touch(p);

  uf::sweep_stale(target);
  EXPECT_FALSE(fs::exists(partial));
  EXPECT_FALSE(fs::exists(target + ".tmp." + dead));
  EXPECT_FALSE(fs::exists(target + ".tmp-faces." + dead));
  for (const fs::path& p : {live, other_host, other_output, not_ours, other_kind}) EXPECT_TRUE(fs::exists(p)) << p;
  EXPECT_TRUE(fs::exists(d / "out" / "metrics.json")) << "the output itself is not a leftover";
  fs::remove_all(d);
}

TEST(Unfinished, AnOldFolderIsPutBackWhenItsRunDiedBetweenTheTwoRenames) {
  // publish_folder's two-rename path moves OUT to OUT.old.<tag> before the new results go
  // in: a run killed in between leaves no OUT, and OUT.old holds the user's results.
  const fs::path d = scratch("old");
  const std::string host = host_of(uf::owner_tag());
  const std::string target = (d / "out").string();
  const fs::path old = target + ".old." + std::to_string(ended_pid()) + host;
  fs::create_directory(old);
  touch(old / "metrics.json", "earlier results");
  uf::sweep_stale(target);
  EXPECT_FALSE(fs::exists(old));
  std::ifstream in(fs::path(target) / "metrics.json");
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "earlier results") << "put back, not removed";

  // With the new results already in place, the set-aside folder is removed.
  fs::create_directory(old);
  touch(old / "metrics.json", "older results");
  uf::sweep_stale(target);
  EXPECT_FALSE(fs::exists(old));
  std::ifstream again(fs::path(target) / "metrics.json");
  std::getline(again, text);
  EXPECT_EQ(text, "earlier results");
  fs::remove_all(d);
}

TEST(Unfinished, PrefixSweepTakesEveryStemStartingWithTheName) {
  const fs::path d = scratch("prefix");
  const std::string host = host_of(uf::owner_tag());
  const std::string dead = std::to_string(ended_pid()) + host;
  const fs::path a = d / ("rayline-blocks-123.partial." + dead), b = d / ("rayline-blocks-456.partial." + dead);
  const fs::path live = d / ("rayline-blocks-789.partial." + uf::owner_tag());
  const fs::path other = d / ("rayline-cache-1.partial." + dead);
  fs::create_directory(a);
  touch(a / "block_0.rlb");
  for (const fs::path& p : {b, live, other}) touch(p);
  uf::sweep_stale((d / "rayline-blocks-").string(), true);
  EXPECT_FALSE(fs::exists(a));
  EXPECT_FALSE(fs::exists(b));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other));
  fs::remove_all(d);
}

TEST(Unfinished, FreshTempNameSweepsFirst) {
  const fs::path d = scratch("fresh");
  const std::string target = (d / "image.exr").string();
  const fs::path stale = target + ".partial." + std::to_string(ended_pid()) + host_of(uf::owner_tag());
  touch(stale);
  EXPECT_EQ(uf::fresh_temp_name(target, "partial"), uf::temp_name(target, "partial"));
  EXPECT_FALSE(fs::exists(stale));
  fs::remove_all(d);
}

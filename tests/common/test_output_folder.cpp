// sched/output_folder: which folders a command may replace, and the swap itself.
#include "common/output_folder.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <thread>
#include <unistd.h>
#include <vector>

#include "common/error.hpp"

namespace fs = std::filesystem;
using rayline::InputError;
using rayline::OwnFiles;

namespace {
const OwnFiles kOwn = {"blocks.json", "block_*.rlb"};

fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("rayline-of-" + std::to_string(::getpid()) + "-" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

std::string message(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(OutputFolder, OnlyFoldersOfTheCommandsOwnFilesAreReplaceable) {
  const fs::path d = scratch("own");
  // Absent and empty folders, and those holding only matching regular files.
  EXPECT_EQ(rayline::replaceable_folder((d / "new").string(), "--out", kOwn), (d / "new").string());
  EXPECT_EQ(rayline::replaceable_folder(d.string() + "/", "--out", kOwn), d.string());
  for (const char* f : {"blocks.json", "block_00000.rlb", "block_123456.rlb", "block_.rlb"}) std::ofstream(d / f) << "x";
  EXPECT_NO_THROW(rayline::replaceable_folder(d.string(), "--out", kOwn));
  // Anything else is named: a near miss of a pattern, a folder, a link with an own name.
  for (const char* f : {"block_1.rlb.bak", "blocks.json~", "xblock_1.rlb", "block_1.rl"}) {
    std::ofstream(d / f) << "x";
    EXPECT_NE(message([&] { rayline::replaceable_folder(d.string(), "--out", kOwn); }).find(std::string("'") + f + "'"),
              std::string::npos)
        << f;
    fs::remove(d / f);
  }
  fs::create_directory(d / "block_9.rlb");
  EXPECT_NE(message([&] { rayline::replaceable_folder(d.string(), "--out", kOwn); }).find("'block_9.rlb'"),
            std::string::npos);
  fs::remove(d / "block_9.rlb");
  fs::create_symlink("/etc/passwd", d / "block_8.rlb");
  EXPECT_NE(message([&] { rayline::replaceable_folder(d.string(), "--out", kOwn); }).find("'block_8.rlb'"),
            std::string::npos);
  fs::remove(d / "block_8.rlb");
  EXPECT_NO_THROW(rayline::replaceable_folder(d.string(), "--out", kOwn));
  // A file, an empty path.
  std::ofstream(d / "file") << "x";
  EXPECT_NE(message([&] { rayline::replaceable_folder((d / "file").string(), "--out", kOwn); }).find("not a folder"),
            std::string::npos);
  EXPECT_NE(message([&] { rayline::replaceable_folder("", "--out", kOwn); }).find("--out: missing output folder"),
            std::string::npos);
  fs::remove_all(d);
}

TEST(OutputFolder, TheCurrentFolderAndEveryFolderAboveItAreRefused) {
  const fs::path d = scratch("cwd");
  fs::create_directories(d / "a" / "b");
  const fs::path before = fs::current_path();
  fs::current_path(d / "a" / "b");
  for (const std::string& p : std::vector<std::string>{".", "./", "..", "../..", (d / "a").string(), "/", "../b"})
    EXPECT_NE(message([&] { rayline::replaceable_folder(p, "--out", {}); }).find("is the current folder or holds it"),
              std::string::npos)
        << p;
  // Beside or below it is fine.
  EXPECT_NO_THROW(rayline::replaceable_folder("../c", "--out", {}));
  EXPECT_NO_THROW(rayline::replaceable_folder("sub", "--out", {}));
  fs::current_path(before);
  fs::remove_all(d);
}

TEST(OutputFolder, PublishSwapsTheFolderAndRestoresTheOldOneOnFailure) {
  const fs::path d = scratch("publish");
  const std::string target = (d / "out").string();
  // New target.
  std::string partial = rayline::partial_folder(target);
  fs::create_directory(partial);
  std::ofstream(fs::path(partial) / "blocks.json") << "1";
  rayline::publish_folder(partial, target, "--out");
  EXPECT_FALSE(fs::exists(partial));
  // Replacing it.
  partial = rayline::partial_folder(target);
  fs::create_directory(partial);
  std::ofstream(fs::path(partial) / "blocks.json") << "2";
  rayline::publish_folder(partial, target, "--out");
  std::ifstream in(fs::path(target) / "blocks.json");
  std::string v;
  in >> v;
  EXPECT_EQ(v, "2");
  // A partial that is gone: the old results stay where they were, and nothing else is left.
  EXPECT_THROW(rayline::publish_folder((d / "missing").string(), target, "--out"), InputError);
  EXPECT_TRUE(fs::exists(fs::path(target) / "blocks.json"));
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(d)) ++n;
  EXPECT_EQ(n, 1u);
  fs::remove_all(d);
}

// Runs publishing into one folder at once (two `simulate --out OUT` started together): the
// last swap wins whole, no run fails, and nothing is left beside OUT. With two renames (the
// old target set aside first) a loser failed and left its OUT.old.<pid> behind.
TEST(OutputFolder, ConcurrentPublishesLeaveOneWholeResultAndNothingElse) {
  const fs::path d = scratch("concurrent");
  const std::string target = (d / "out").string();
  constexpr int kThreads = 4, kRounds = 40;
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < kRounds; ++i) {
        const std::string tag = std::to_string(t) + "-" + std::to_string(i);
        const fs::path partial = target + ".partial." + tag;  // (one process: the pid is shared)
        fs::create_directory(partial);
        std::ofstream(partial / "blocks.json") << tag;
        std::ofstream(partial / "block_0.rlb") << tag;
        try {
          rayline::publish_folder(partial.string(), target, "--out");
        } catch (const InputError&) {
          ++failures;
        }
      }
    });
  for (std::thread& th : threads) th.join();
  EXPECT_EQ(failures.load(), 0);
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(d)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"out"});
  auto read = [&](const char* f) {
    std::ifstream in(fs::path(target) / f);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_FALSE(read("blocks.json").empty());
  EXPECT_EQ(read("blocks.json"), read("block_0.rlb"));  // one run's files, not a mix
  fs::remove_all(d);
}

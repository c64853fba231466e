// common/output_folder: a folder of result folders (compare's OUT/<scheduler>/, a client
// sweep's OUT/clients-N/) is replaceable only when it holds nothing but the command's own
// files and its own result folders, each of which its own check accepts.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "common/output_folder.hpp"

namespace fs = std::filesystem;
using rayline::InputError;
using rayline::OwnFiles;

namespace {
const OwnFiles kTables = {"compare.csv", "compare.json"};
const OwnFiles kRuns = {"gmb", "budge"};
const OwnFiles kRunFiles = {"metrics.json", "jobs.csv"};

fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("rayline-rsf-" + std::to_string(::getpid()) + "-" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

// The check of one result folder: its own files only (as sim::check_results_folder).
void check_run(const std::string& dir) { rayline::replaceable_folder(dir, "--out", kRunFiles); }

std::string message(const fs::path& d) {
  try {
    rayline::replaceable_folder(d.string(), "--out", kTables, kRuns, check_run);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(ResultSetFolder, OwnTablesAndOwnResultFoldersOnly) {
  const fs::path d = scratch("set");
  EXPECT_EQ(message(d), "") << "empty";
  std::ofstream(d / "compare.csv") << "x";
  fs::create_directories(d / "gmb");
  std::ofstream(d / "gmb" / "metrics.json") << "{}";
  fs::create_directories(d / "budge");  // empty: a run folder still being replaced
  EXPECT_EQ(message(d), "");
  // A user's file inside a result folder is named by that folder's check.
  std::ofstream(d / "gmb" / "notes.txt") << "mine";
  EXPECT_NE(message(d).find("gmb: --out: folder holds 'notes.txt'"), std::string::npos) << message(d);
  fs::remove(d / "gmb" / "notes.txt");
  // Anything else at the top: a file, a folder of another name, a file bearing a run's name,
  // a link to a folder bearing a run's name.
  std::ofstream(d / "thesis.tex") << "mine";
  EXPECT_NE(message(d).find("folder holds 'thesis.tex'"), std::string::npos) << message(d);
  fs::remove(d / "thesis.tex");
  fs::create_directories(d / "photos");
  EXPECT_NE(message(d).find("folder holds 'photos'"), std::string::npos) << message(d);
  fs::remove(d / "photos");
  fs::remove_all(d / "budge");
  std::ofstream(d / "budge") << "mine";
  EXPECT_NE(message(d).find("folder holds 'budge'"), std::string::npos) << message(d);
  fs::remove(d / "budge");
  const fs::path elsewhere = scratch("elsewhere");
  fs::create_directory_symlink(elsewhere, d / "budge");
  EXPECT_NE(message(d).find("folder holds 'budge'"), std::string::npos) << message(d);
  fs::remove(d / "budge");
  EXPECT_EQ(message(d), "");
  // Without a check, folders are never accepted (the files-only rule).
  EXPECT_THROW(rayline::replaceable_folder(d.string(), "--out", kTables, kRuns, {}), InputError);
  fs::remove_all(d);
  fs::remove_all(elsewhere);
}

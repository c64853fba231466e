// `rayline report RUN_DIR`: the page written (default and --out), the path printed, and
// bad input (a missing folder, a folder that is not a run's, malformed files) exiting 2
// with a message naming the folder or file, and nothing written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "apps/run_folder_fixture.hpp"
#include "cli/cli_run.hpp"
#include "cli/scratch_test.hpp"

namespace fs = std::filesystem;
using rayline::testing::rayline_cli;
using rayline::testing::write_text_file;

namespace {

class CliReport : public rayline::testing::ScratchTest {
 protected:
  std::string slurp(const std::string& p) const {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  // Only the files a test wrote itself are in `dir` (no page, no temporary left).
  std::size_t files_in(const fs::path& dir) const {
    std::size_t n = 0;
    for (const auto& e : fs::recursive_directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
    return n;
  }
};

TEST_F(CliReport, WritesRunDirReportHtmlAndPrintsThePath) {
  rayline::testing::write_simulate_run(dir_ / "run");
  const auto r = rayline_cli("report " + path("run"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(r.out, "wrote " + path("run/report.html") + "\n");
  const std::string page = slurp(path("run/report.html"));
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(page.find("<svg id=\"chart-gantt\""), std::string::npos);
  EXPECT_EQ(files_in(dir_ / "run"), 3u);  // metrics.json, jobs.csv, report.html: no temporary left
}

TEST_F(CliReport, OutNamesThePage) {
  rayline::testing::write_render_run(dir_ / "r");
  const auto r = rayline_cli("report " + path("r") + " --out " + path("pages/room.html"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(slurp(path("pages/room.html")).find("id=\"render-image\""), std::string::npos);
  EXPECT_FALSE(fs::exists(path("r/report.html")));
}

TEST_F(CliReport, HelpDescribesTheArgumentAndFlag) {
  const auto r = rayline_cli("report --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("RUN_DIR"), std::string::npos);
  EXPECT_NE(r.out.find("--out"), std::string::npos);
  EXPECT_NE(r.out.find("default: RUN_DIR/report.html"), std::string::npos);
}

TEST_F(CliReport, MissingFolderExits2NamingIt) {
  const auto r = rayline_cli("report " + path("nowhere"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("rayline: " + path("nowhere") + ": no such folder"), std::string::npos) << r.err;
}

TEST_F(CliReport, FolderWithoutMetricsExits2SayingWhatIsMissing) {
  fs::create_directories(path("empty"));
  write_text_file(dir_ / "empty" / "jobs.csv", rayline::testing::simulate_jobs());
  const auto r = rayline_cli("report " + path("empty"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(path("empty") + ": not a run folder: it holds no metrics.json"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("empty/report.html")));
}

TEST_F(CliReport, MalformedMetricsExits2NamingTheFile) {
  write_text_file(dir_ / "run" / "metrics.json", "{\"devices\": [");
  auto r = rayline_cli("report " + path("run"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("rayline: " + path("run/metrics.json") + ": invalid JSON"), std::string::npos) << r.err;
  write_text_file(dir_ / "run" / "metrics.json", "{\"devices\": [{\"name\": \"A.cpu0\", \"busy_s\": \"long\"}]}");
  r = rayline_cli("report " + path("run"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(path("run/metrics.json") + ": devices[0].busy_s: expected a number"), std::string::npos) << r.err;
  EXPECT_EQ(files_in(dir_ / "run"), 1u);
}

TEST_F(CliReport, MalformedJobsCsvExits2NamingFileLineAndColumn) {
  rayline::testing::write_simulate_run(dir_ / "run");
  write_text_file(dir_ / "run" / "jobs.csv", rayline::testing::simulate_jobs() + "5,E,j,Shade,A.cpu0,,1,0,soon,0,1,done,0\n");
  const auto r = rayline_cli("report " + path("run"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(path("run/jobs.csv") + ": line 7: planned_end: expected a number, got 'soon'"), std::string::npos)
      << r.err;
}

TEST_F(CliReport, OutMayNotReplaceAFileTheReportReads) {
  rayline::testing::write_simulate_run(dir_ / "run");
  const std::string before = slurp(path("run/jobs.csv"));
  const auto r = rayline_cli("report " + path("run") + " --out " + path("run/jobs.csv"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--out"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(path("run/jobs.csv")), before);
}

TEST_F(CliReport, CompareFolderGetsOnePage) {
  rayline::testing::write_compare_run(dir_ / "cmp");
  const auto r = rayline_cli("report " + path("cmp"));
  ASSERT_EQ(r.code, 0) << r.all;
  const std::string page = slurp(path("cmp/report.html"));
  EXPECT_NE(page.find("<svg id=\"chart-compare-throughput\""), std::string::npos);
  EXPECT_NE(page.find("<svg id=\"budge-chart-devices\""), std::string::npos);
}

}  // namespace

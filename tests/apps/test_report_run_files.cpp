// Reading run folders for `rayline report`, and the numbers behind its charts.
#include <gtest/gtest.h>

#include <cmath>

#include "apps/report/run_files.hpp"
#include "apps/report/run_stats.hpp"
#include "apps/run_folder_fixture.hpp"
#include "cli/scratch_test.hpp"
#include "common/error.hpp"

namespace rayline::report {
namespace {

using rayline::testing::ScratchTest;
using rayline::testing::write_text_file;

class ReportFiles : public ScratchTest {
 protected:
  // The message of the InputError that reading `dir` throws ("" when none is thrown).
  std::string error_of(const std::string& dir) {
    try {
      read_run_folder(dir);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
};

TEST(ReportCsv, SplitsQuotedCells) {
  EXPECT_EQ(split_csv_line("a,\"b, c\",,d\r"), (std::vector<std::string>{"a", "b, c", "", "d"}));
  EXPECT_EQ(split_csv_line("\"say \"\"hi\"\"\",x"), (std::vector<std::string>{"say \"hi\"", "x"}));
}

TEST_F(ReportFiles, ReadsASimulateFolder) {
  rayline::testing::write_simulate_run(dir_);
  const RunFolder f = read_run_folder(dir_.string());
  EXPECT_EQ(f.kind, RunFolder::Kind::simulate);
  ASSERT_EQ(f.runs.size(), 1u);
  const RunData& r = f.runs[0];
  EXPECT_EQ(r.command, "rayline simulate --out x <b>");
  EXPECT_EQ(r.version, "0.1.0");
  EXPECT_EQ(r.scheduler, "gmb");
  EXPECT_DOUBLE_EQ(r.run_seconds, 4.0);
  EXPECT_EQ(r.rays_per_second_series.size(), 4u);
  ASSERT_EQ(r.devices.size(), 2u);
  EXPECT_EQ(r.devices[1].kind, "gpu");
  EXPECT_DOUBLE_EQ(r.devices[1].setup_s, 0.5);
  ASSERT_EQ(r.channels.size(), 2u);
  EXPECT_TRUE(r.channels[1].lan);
  ASSERT_EQ(r.activities.size(), 5u);
  EXPECT_EQ(r.activities[0].kind, 'T');
  EXPECT_FALSE(r.activities[4].actual_start.has_value());
  EXPECT_DOUBLE_EQ(*r.activities[1].created, 0.5);
  bool lan_fact = false;
  for (const Fact& fact : r.facts)
    if (fact.label == "LAN utilisation (mean)") lan_fact = fact.value && *fact.value == 0.25 && fact.unit == "%";
  EXPECT_TRUE(lan_fact);
}

TEST_F(ReportFiles, ReadsARenderFolderByItsImageStem) {
  rayline::testing::write_render_run(dir_, "room");
  const RunFolder f = read_run_folder(dir_.string());
  EXPECT_EQ(f.kind, RunFolder::Kind::render);
  ASSERT_EQ(f.runs.size(), 1u);
  EXPECT_EQ(f.runs[0].label, "room");
  EXPECT_EQ(f.runs[0].png, "foobar");
  ASSERT_EQ(f.runs[0].devices.size(), 1u);
  EXPECT_EQ(f.runs[0].devices[0].kind, "cpu");
  EXPECT_DOUBLE_EQ(f.runs[0].devices[0].fetching_s, 0.5);
  EXPECT_EQ(f.runs[0].activities.size(), 3u);
}

TEST_F(ReportFiles, ReadsACompareFolderWithEachSchedulersRun) {
  rayline::testing::write_compare_run(dir_);
  const RunFolder f = read_run_folder(dir_.string());
  EXPECT_EQ(f.kind, RunFolder::Kind::compare);
  ASSERT_TRUE(f.compare);
  EXPECT_EQ(f.compare->rows.size(), 2u);
  EXPECT_EQ(f.compare->cell(0, "scheduler_parameters"), "gmb{k=2s; a, b}");
  EXPECT_EQ(f.compare->cell(1, "no such column"), "");
  ASSERT_EQ(f.runs.size(), 2u);
  EXPECT_EQ(f.runs[1].label, "budge");
  EXPECT_EQ(f.runs[1].scheduler, "budge");
}

TEST_F(ReportFiles, ReadsAClientSweepInClientOrder) {
  rayline::testing::write_sweep_run(dir_);
  const RunFolder f = read_run_folder(dir_.string());
  EXPECT_EQ(f.kind, RunFolder::Kind::sweep);
  ASSERT_EQ(f.runs.size(), 2u);
  EXPECT_EQ(f.runs[0].label, "clients-2");
  EXPECT_EQ(f.runs[1].label, "clients-10");
  EXPECT_EQ(f.runs[1].activities.size(), 5u);
}

TEST_F(ReportFiles, NamesWhatIsMissingOrMalformed) {
  EXPECT_NE(error_of(path("nowhere")).find("nowhere: no such folder"), std::string::npos);
  EXPECT_NE(error_of(dir_.string()).find("not a run folder: it holds no metrics.json"), std::string::npos);
  write_text_file(dir_ / "metrics.json", "{\"devices\": [ {\"name\": 3} ]}");
  EXPECT_NE(error_of(dir_.string()).find("metrics.json: devices[0].name: expected a string"), std::string::npos);
  write_text_file(dir_ / "metrics.json", "{\"rays_per_second_series\": [1, \"x\"]}");
  EXPECT_NE(error_of(dir_.string()).find("rays_per_second_series[1]: expected a number"), std::string::npos);
  write_text_file(dir_ / "metrics.json", "{");
  EXPECT_NE(error_of(dir_.string()).find("metrics.json: invalid JSON"), std::string::npos);
}

TEST_F(ReportFiles, RejectsMalformedJobsCsvNamingLineAndColumn) {
  write_text_file(dir_ / "metrics.json", "{}");
  std::string jobs = rayline::testing::simulate_jobs();
  write_text_file(dir_ / "jobs.csv", jobs + "5,E,j,Shade,A.cpu0,,lots,0,1,0,1,done,0\n");
  EXPECT_NE(error_of(dir_.string()).find("jobs.csv: line 7: bytes: expected a number, got 'lots'"), std::string::npos);
  write_text_file(dir_ / "jobs.csv", jobs + "5,X,j,Shade,A.cpu0,,1,0,1,0,1,done,0\n");
  EXPECT_NE(error_of(dir_.string()).find("line 7: kind: expected E or T"), std::string::npos);
  write_text_file(dir_ / "jobs.csv", jobs + "5,E,j\n");
  EXPECT_NE(error_of(dir_.string()).find("line 7: 3 cells, the header has 13"), std::string::npos);
  write_text_file(dir_ / "jobs.csv", "activity,kind\n");
  EXPECT_NE(error_of(dir_.string()).find("jobs.csv: header: missing column 'job'"), std::string::npos);
}

TEST_F(ReportFiles, RefusesASchedulerNameLeavingTheFolder) {
  write_text_file(dir_ / "compare.csv", "scheduler,status\n../etc,ok\n");
  EXPECT_NE(error_of(dir_.string()).find("compare.csv: line 2: scheduler: '../etc' is not a scheduler's folder name"),
            std::string::npos);
}

TEST(ReportStats, ThroughputComesFromTheSeriesOrFromFinishedEJobs) {
  RunData r;
  r.rays_per_second_series = {1, 2};
  const Throughput a = throughput(r);
  EXPECT_EQ(a.x, (std::vector<double>{0.5, 1.5}));
  EXPECT_EQ(a.unit, "rays/s");
  r.rays_per_second_series.clear();
  r.activities.push_back({'E', "j", "RayIntersect", "W.cpu0", "", "done", 800, 0, 1, 0.0, 1.0, 0.0});
  r.activities.push_back({'E', "k", "RayIntersect", "W.cpu0", "", "done", 400, 0, 1, 0.0, 0.5, 0.0});
  r.activities.push_back({'T', "k", "transfer", "W.disk", "", "done", 1e9, 0, 1, 0.0, 0.2, 0.0});  // not counted
  const Throughput b = throughput(r, 2);
  EXPECT_EQ(b.unit, "B/s");
  ASSERT_EQ(b.values.size(), 2u);
  EXPECT_DOUBLE_EQ(b.values[0], 0.0);          // [0, 0.5): nothing finished
  EXPECT_DOUBLE_EQ(b.values[1], 1200 / 0.5);   // [0.5, 1]: both
}

TEST(ReportStats, BinsClampValuesOutsideTheRange) {
  EXPECT_EQ(bin_of(0.0, 0, 0.5, 4), 0u);
  EXPECT_EQ(bin_of(0.6, 0, 0.5, 4), 1u);
  EXPECT_EQ(bin_of(2.0, 0, 0.5, 4), 3u);  // the upper end is in the last bin
  EXPECT_EQ(bin_of(1e300, 0, 0.5, 4), 3u);
  EXPECT_EQ(bin_of(-3, 0, 0.5, 4), 0u);
  EXPECT_EQ(bin_of(std::nan(""), 0, 0.5, 4), 0u);
}

TEST(ReportStats, ManyDevicesAreGroupedPerNodeAndKind) {
  std::vector<DeviceTime> d;
  for (int i = 0; i < 4; ++i) d.push_back({"A0.cpu" + std::to_string(i), "cpu", 1, 0, 2, 1});
  d.push_back({"A0.gpu0", "gpu", 3, 0, 1, 0});
  EXPECT_EQ(device_rows(d, 8).size(), 5u);
  const std::vector<DeviceRow> rows = device_rows(d, 3);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].name, "A0 cpu x4");
  EXPECT_DOUBLE_EQ(rows[0].fetching_s, 8);
  EXPECT_EQ(rows[1].name, "A0 gpu x1");
}

TEST(ReportStats, ChannelUseIsTheUnionOfTransfersOverTheRun) {
  RunData r;
  r.run_seconds = 2.0;
  r.activities.push_back({'T', "a", "transfer", "W.disk", "s0", "done", 100, 0, 1, 0.0, 0.5, 0.0});
  r.activities.push_back({'T', "b", "transfer", "W.disk", "s1", "done", 100, 0, 1, 0.25, 1.0, 0.0});
  r.activities.push_back({'T', "c", "transfer", "W.disk", "s2", "planned", 100, 1, 2, std::nullopt, std::nullopt, 0.0});
  const std::vector<ChannelUse> use = channel_use(r);
  ASSERT_EQ(use.size(), 1u);
  EXPECT_DOUBLE_EQ(use[0].utilisation, 0.5);
  EXPECT_DOUBLE_EQ(use[0].bytes, 200);
  r.channels.push_back({"from metrics", 0.9, 0, false});
  EXPECT_EQ(channel_use(r).at(0).name, "from metrics");
}

TEST(ReportStats, QueueWaitsPerTypeAndOverall) {
  const std::vector<Activity> a = [] {
    std::vector<Activity> v;
    v.push_back({'E', "j0", "RayIntersect", "A.cpu0", "", "done", 1, 1, 2, 1.5, 2.5, 0.5});
    v.push_back({'E', "j1", "Shade", "A.gpu0", "", "done", 1, 0, 1, 0.0, 1.0, 0.0});
    v.push_back({'E', "j2", "Shade", "A.gpu0", "", "done", 1, 1, 3, 3.0, 4.0, 0.0});
    v.push_back({'E', "j3", "Shade", "A.gpu0", "", "planned", 1, 3, 4, std::nullopt, std::nullopt, 2.5});
    return v;
  }();
  EXPECT_EQ(queue_waits(a).size(), 3u);
  const std::vector<WaitStats> s = wait_stats(a);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].type, "RayIntersect");
  EXPECT_DOUBLE_EQ(s[0].p50, 1.0);
  EXPECT_EQ(s[1].type, "Shade");
  EXPECT_EQ(s[1].count, 2u);
  EXPECT_DOUBLE_EQ(s[1].max, 3.0);
  EXPECT_EQ(s[2].type, "all");
  EXPECT_DOUBLE_EQ(s[2].p50, 1.0);
  EXPECT_DOUBLE_EQ(percentile({5, 1, 3, 2, 4}, 0.95), 5);
}

TEST(ReportStats, GanttKeepsTheBusiestRowsAndCapsTheBars) {
  std::vector<Activity> a;
  for (int i = 0; i < 50; ++i)
    a.push_back({'E', "j", "Shade", "dev" + std::to_string(i % 5), "", "done", 1, double(i), i + 1.0, double(i),
                 i + 0.5 + (i % 5 == 0 ? 0.4 : 0.0), 0.0});
  const GanttView g = gantt_view(a, 2, 20);
  ASSERT_EQ(g.rows.size(), 2u);
  EXPECT_EQ(g.rows[0], "dev0");  // the longest actual time
  EXPECT_EQ(g.bars.size(), 20u);  // 10 activities, planned and actual each
  EXPECT_EQ(g.shown_activities, 10u);
  EXPECT_EQ(g.row_activities, 20u);
  EXPECT_DOUBLE_EQ(g.t0, 0.0);
  EXPECT_LE(g.t1, 26.0);  // ends where the first activity left out starts
}

}  // namespace
}  // namespace rayline::report

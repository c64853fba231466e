// `rayline plan` and `rayline simulate` from the outside: defaults run, outputs are
// complete and in standard formats, bad input exits 2 with the file and field named and
// leaves no partial result behind.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "cli_run.hpp"

using rayline::testing::rayline_cli;
namespace fs = std::filesystem;

namespace {
fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("rayline-cli-" + std::to_string(::getpid()) + "-" + name);
  fs::remove_all(p);
  return p;
}
const std::string kPlatforms = RAYLINE_PLATFORMS;
const std::string kData = RAYLINE_TEST_DATA;
}  // namespace

TEST(CliPlan, HelpAndVersion) {
  EXPECT_EQ(rayline_cli("--help").code, 0);
  const auto v = rayline_cli("--version");
  EXPECT_EQ(v.code, 0);
  EXPECT_NE(v.all.find("rayline"), std::string::npos);
  EXPECT_EQ(rayline_cli("plan --help").code, 0);
  EXPECT_EQ(rayline_cli("simulate --help").code, 0);
  EXPECT_EQ(rayline_cli("no-such-command").code, 2);
  EXPECT_EQ(rayline_cli("plan --no-such-flag").code, 2);
}

TEST(CliPlan, DefaultsRunOnThePaperClusterAndWriteTraceAndCsv) {
  const fs::path dir = scratch("plan");
  fs::create_directories(dir);
  const auto r = rayline_cli("plan --quiet --synthetic-jobs 300 --trace " + (dir / "t.json").string() + " --jobs-csv " +
                             (dir / "j.csv").string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.all.find("makespan"), std::string::npos);
  EXPECT_NE(r.all.find("84 compute devices"), std::string::npos) << r.all;
  std::ifstream t(dir / "t.json");
  const auto trace = nlohmann::json::parse(t);
  EXPECT_GT(trace["traceEvents"].size(), 300u);
  EXPECT_TRUE(fs::exists(dir / "j.csv"));
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << "temporary file left: " << e.path();
  fs::remove_all(dir);
}

TEST(CliPlan, JobFileOnAPlatformSubset) {
  const auto r = rayline_cli("plan --platform " + kPlatforms + "/paper-2A.json --jobs " + kData + "/jobs/fig4.json");
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.all.find("E-jobs 2"), std::string::npos) << r.all;
}

// A horizon below the clock's resolution once the run is under way (now + k == now):
// every dry device still gets a job, so everything is placed (it used to stall with
// "could not be placed on any device").
TEST(CliPlan, HorizonBelowTheClockResolutionPlacesEveryJob) {
  const auto r = rayline_cli("plan --quiet --synthetic-jobs 200 --horizon 1e-300s");
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(r.err.find("could not be placed"), std::string::npos) << r.err;
  EXPECT_NE(r.all.find("E-jobs 200"), std::string::npos) << r.all;
}

// Jobs no device can ever run are reported with the reason, not as "capacity or no path":
// one 27 GB block fits no memory device of the cluster.
TEST(CliPlan, UnplaceableJobsAreExplained) {
  const auto r = rayline_cli("plan --quiet --synthetic-blocks 1 --synthetic-jobs 3");
  EXPECT_EQ(r.code, 1) << r.all;
  EXPECT_NE(r.err.find("3 job(s) could not be placed on any device; job 'ri0': its inputs and outputs need"),
            std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(D.gpu0mem) holds 12.9 GB"), std::string::npos) << r.err;
}

TEST(CliPlan, BadInputExitsTwoNamingFileAndField) {
  auto r = rayline_cli("plan --horizon 0s");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.all.find("--horizon"), std::string::npos) << r.all;
  r = rayline_cli("plan --horizon two");
  EXPECT_EQ(r.code, 2);
  r = rayline_cli("plan --jobs /nonexistent/jobs.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.all.find("/nonexistent/jobs.json"), std::string::npos) << r.all;
  r = rayline_cli("plan --platform /nonexistent/platform.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.all.find("/nonexistent/platform.json"), std::string::npos) << r.all;
  const fs::path bad = scratch("bad-jobs.json");
  std::ofstream(bad) << R"({"blocks": [{"name": "b", "kind": "SceneData", "size": "1MB", "at": ["Z9.ram"]}], "jobs": []})";
  r = rayline_cli("plan --jobs " + bad.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.all.find("blocks[0].at"), std::string::npos) << r.all;
  r = rayline_cli("plan --synthetic-jobs 10 --trace /proc/rayline-cannot-create/trace.json");
  EXPECT_EQ(r.code, 2);
  fs::remove(bad);
}

// --aging reaches GMB (Sec. 4.3) and changes what it does on a saturating stream, and
// metrics.json reports how long E-jobs waited in the queue.
TEST(CliSimulate, AgingFlagReachesGmbAndQueueWaitsAreReported) {
  auto run = [](const std::string& aging) {
    const fs::path out = scratch("sim-aging-" + aging);
    const auto r = rayline_cli("simulate --duration 20s --no-progress --aging " + aging + " --out " + out.string());
    EXPECT_EQ(r.code, 0) << r.all;
    std::ifstream f(out / "metrics.json");
    auto m = nlohmann::json::parse(f);
    std::ifstream jobs(out / "jobs.csv");
    m["jobs_csv"] = std::string(std::istreambuf_iterator<char>(jobs), {});
    fs::remove_all(out);
    return m;
  };
  const auto off = run("off"), two = run("2s"), adaptive = run("adaptive");
  EXPECT_NE(adaptive["scheduler_parameters"].get<std::string>().find("adaptive_aging=1"), std::string::npos)
      << adaptive["scheduler_parameters"];
  EXPECT_NE(off["scheduler_parameters"].get<std::string>().find("aging=off"), std::string::npos) << off["scheduler_parameters"];
  EXPECT_NE(two["scheduler_parameters"].get<std::string>().find("aging=2.0"), std::string::npos) << two["scheduler_parameters"];
  EXPECT_NE(off["jobs_csv"], two["jobs_csv"]) << "aging after 2 s must change the schedule of a saturating 20 s stream";
  for (const auto* m : {&off, &two, &adaptive}) {
    const auto& w = (*m)["queue_wait_s"];
    const double p50 = w["p50"], p95 = w["p95"], mx = w["max"], mean = w["mean"], oldest = w["oldest_queued_at_end"];
    EXPECT_GT(p50, 0);
    EXPECT_LE(p50, p95);
    EXPECT_LE(p95, mx);
    EXPECT_LE(mean, mx);
    EXPECT_LE(mx, 20.0);
    EXPECT_GT(oldest, 0);
    EXPECT_LE(oldest, 20.0);
  }
}

TEST(CliSimulate, ShortRunWritesCompleteResults) {
  const fs::path out = scratch("sim");
  const auto r = rayline_cli("simulate --platform paper-A --duration 5s --no-progress --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  std::ifstream f(out / "metrics.json");
  const auto m = nlohmann::json::parse(f);
  for (const char* key : {"rays_per_second", "rays_per_second_series", "devices", "device_summary", "resources",
                          "lan_utilisation_mean", "prediction_error", "scheduler_cost", "simulator"})
    EXPECT_TRUE(m.contains(key)) << key;
  EXPECT_GT(m["rays_per_second"].get<double>(), 0);
  EXPECT_DOUBLE_EQ(m["simulated_s"].get<double>(), 5.0);
  EXPECT_TRUE(fs::exists(out / "jobs.csv"));
  {  // jobs.csv: every row has the header's 13 fields; a done E-job started no earlier than it was created
    std::ifstream csv(out / "jobs.csv");
    std::string line;
    std::getline(csv, line);
    EXPECT_EQ(line.substr(line.rfind(',') + 1), "created");
    int done_execs = 0;
    while (std::getline(csv, line)) {
      std::vector<std::string> f;
      std::istringstream ls(line);
      for (std::string x; std::getline(ls, x, ',');) f.push_back(x);
      if (!line.empty() && line.back() == ',') f.push_back("");
      ASSERT_EQ(f.size(), 13u) << line;
      if (f[1] == "E" && f[11] == "done") {
        ++done_execs;
        EXPECT_GE(std::stod(f[9]), std::stod(f[12]) - 1e-9) << line;
      }
    }
    EXPECT_GT(done_execs, 0);
  }
  std::ifstream t(out / "timeline.json");
  EXPECT_TRUE(nlohmann::json::parse(t).contains("traceEvents"));
  // --no-timeline: the same results without the trace.
  const auto nt = rayline_cli("simulate --platform paper-A --duration 5s --no-progress --no-timeline --out " + out.string());
  ASSERT_EQ(nt.code, 0) << nt.all;
  EXPECT_TRUE(fs::exists(out / "metrics.json"));
  EXPECT_TRUE(fs::exists(out / "jobs.csv"));
  EXPECT_FALSE(fs::exists(out / "timeline.json"));
  EXPECT_EQ(nt.out.find("timeline.json"), std::string::npos) << nt.out;
  fs::remove_all(out);
}

TEST(CliSimulate, BadInputExitsTwoAndLeavesNoOutputDirectory) {
  const fs::path out = scratch("sim-bad");
  // A platform that fails validation, and a workload file with an error in it.
  const fs::path bad_platform = scratch("bad-platform.json");
  std::ofstream(bad_platform) << R"({"name": "x", "node_types": {"N": {"memory": [{"name": "ram", "kind": "host", "capacity": "8GiB"}],
      "compute": [{"name": "cpu", "kind": "cpu", "memory": "ram"}]}}, "nodes": [{"name": "n", "type": "N"}]})";
  const fs::path bad_jobs = scratch("bad-jobs.json");
  std::ofstream(bad_jobs) << R"({"blocks": [{"name": "b", "kind": "SceneData", "size": "1MB", "at": ["A0.disk"]}], "jobs": [{"name": "j", "type": "RayIntersect", "inputs": ["missing"]}]})";
  const std::vector<std::pair<std::string, fs::path>> cases = {
      {"--platform " + bad_platform.string(), bad_platform},
      {"--workload " + bad_jobs.string() + " --platform paper-A", bad_jobs}};
  for (const auto& [args, file] : cases) {
    const auto r = rayline_cli("simulate --no-progress --out " + out.string() + " " + args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.all;
    EXPECT_NE(r.err.find(file.string()), std::string::npos) << "the message names the file: " << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
  fs::remove(bad_platform);
  fs::remove(bad_jobs);
  for (const std::string args : {"--scheduler teleport", "--duration 0s", "--duration 1e-300s", "--horizon -1s", "--workload /nonexistent/jobs.json",
                                 "--platform /nonexistent.json", "--exec-noise 2", "--exec-noise nan", "--blocks 1", "--aging soon",
                                 "--aging -2s", "--transfer-order fifo", "--seed -1", "--seed 18446744073709551616",
                                 "--seed 1e3", "--rayline-off ownership", "--scheduler rayline --rayline-off teleport"}) {
    const auto r = rayline_cli("simulate --no-progress --out " + out.string() + " " + args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.all;
    EXPECT_FALSE(fs::exists(out)) << args;
    bool partial = false;
    for (const auto& e : fs::directory_iterator(out.parent_path()))
      partial = partial || e.path().filename().string().starts_with(out.filename().string() + ".partial");
    EXPECT_FALSE(partial) << args;
  }
}

// A ray stream never drains, so the runtime loop cannot see a stall. With 100 MB of RAM on
// the one node nothing can run (blocks reach the GPU only through RAM): the run says so,
// exits 1 and records "stalled" in metrics.json (it used to report 0 rays/s and exit 0).
TEST(CliSimulate, AStreamNoDeviceCanRunIsAStall) {
  const fs::path out = scratch("sim-stall");
  const fs::path platform = scratch("small-ram.json");
  auto p = nlohmann::json::parse(std::ifstream(kPlatforms + "/paper-A.json"));
  p["node_types"]["A"]["memory"][1]["capacity"] = "100MB";
  std::ofstream(platform) << p.dump();
  const auto r = rayline_cli("simulate --no-progress --duration 5s --platform " + platform.string() + " --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.all;
  EXPECT_NE(r.err.find("on A0.gpu0: no chain of channels"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("leads from its holders to A0.gpu0mem"), std::string::npos) << r.err;
  const auto m = nlohmann::json::parse(std::ifstream(out / "metrics.json"));
  EXPECT_TRUE(m.at("stalled").get<bool>());
  fs::remove_all(out);
  fs::remove(platform);
}

// --transfer-order: with the plan's order on every resource nothing contends, so on the
// paper cluster every T-job takes exactly its predicted time and the run ends when the plan
// said; by default LAN channels out of one NIC run at once and their times depart from it.
TEST(CliSimulate, TransferOrderResourceMakesThePlanExactOnTheCluster) {
  auto run = [](const std::string& order) {
    const fs::path out = scratch("sim-order-" + order);
    const auto r = rayline_cli("simulate --duration 20s --no-progress --no-timeline --transfer-order " + order +
                               " --out " + out.string());
    EXPECT_EQ(r.code, 0) << r.all;
    std::ifstream f(out / "metrics.json");
    auto m = nlohmann::json::parse(f);
    fs::remove_all(out);
    return m;
  };
  const auto channel = run("channel"), resource = run("resource"), exclusive = run("exclusive");
  EXPECT_EQ(resource["transfer_order"], "resource");
  EXPECT_EQ(channel["transfer_order"], "channel");
  EXPECT_LT(resource["prediction_error"]["transfer_mean_rel"].get<double>(), 1e-9);
  EXPECT_LT(std::abs(resource["makespan_s"]["gap"].get<double>()), 1e-9);
  EXPECT_GT(channel["prediction_error"]["transfer_mean_rel"].get<double>(), 0.1);
  // exclusive: one T-job per resource at a time, so durations are exact too; starts are not.
  EXPECT_LT(exclusive["prediction_error"]["transfer_mean_rel"].get<double>(), 1e-9);
  for (const auto* m : {&channel, &resource, &exclusive}) EXPECT_GT((*m)["rays_per_second"].get<double>(), 0);
  // The same on other seeds, a platform subset, and path tracing on the workstation (four
  // GPUs' PCIe links on one root medium). There rays that join a planned E-job re-time it
  // (--retime-merged), so only the T-jobs keep their planned times.
  for (const std::string args : {"--duration 10s --seed 2", "--duration 10s --seed 3 --platform paper-4A+B",
                                 "--duration 3s --platform workstation-4gpu --workload museum --clients 8"}) {
    const fs::path out = scratch("sim-order-more");
    const auto r = rayline_cli("simulate --no-progress --no-timeline --transfer-order resource " + args + " --out " +
                               out.string());
    ASSERT_EQ(r.code, 0) << args << ": " << r.all;
    std::ifstream f(out / "metrics.json");
    const auto m = nlohmann::json::parse(f);
    fs::remove_all(out);
    EXPECT_LT(m["prediction_error"]["transfer_mean_rel"].get<double>(), 1e-9) << args;
    if (args.find("museum") == std::string::npos) {
      EXPECT_LT(std::abs(m["makespan_s"]["gap"].get<double>()), 1e-9) << args;
    }
    EXPECT_GT(m["activities"]["t_jobs_done"].get<double>(), 10) << args;
  }
}

// `rayline compare`: one run per scheduler, a table, compare.csv and compare.json; a bad
// flag is reported before any scheduler runs, and nothing is written.
TEST(CliCompare, RunsEverySchedulerAndRejectsBadFlagsBeforeRunning) {
  const fs::path out = scratch("compare");
  auto r = rayline_cli("compare --schedulers gmb,budge --platform paper-A --duration 3s --aging adaptive --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("== gmb =="), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("== budge =="), std::string::npos) << r.out;
  std::ifstream csv(out / "compare.csv");
  std::string line;
  int rows = 0;
  std::getline(csv, line);  // header
  while (std::getline(csv, line)) rows += !line.empty();
  EXPECT_EQ(rows, 2);
  std::ifstream js(out / "compare.json");
  const auto rows_json = nlohmann::json::parse(js);
  EXPECT_EQ(rows_json.size(), 2u);
  for (const auto& row : rows_json) {  // the queue waits of each run's metrics.json
    std::ifstream mf(out / row["scheduler"].get<std::string>() / "metrics.json");
    const auto w = nlohmann::json::parse(mf)["queue_wait_s"];
    EXPECT_DOUBLE_EQ(row["queue_wait_p50_s"].get<double>(), w["p50"].get<double>()) << row;
    EXPECT_DOUBLE_EQ(row["queue_wait_p95_s"].get<double>(), w["p95"].get<double>()) << row;
  }
  EXPECT_NE(r.out.find("wait p50/p95 s"), std::string::npos) << r.out;
  std::ifstream m(out / "gmb" / "metrics.json");
  EXPECT_NE(nlohmann::json::parse(m)["scheduler_parameters"].get<std::string>().find("adaptive_aging=1"), std::string::npos);
  fs::remove_all(out);
  for (const std::string args : {"--aging soon", "--horizon 2x", "--duration -5s", "--schedulers gmb,teleport", "--schedulers gmb,budge,gmb"}) {
    r = rayline_cli("compare --platform paper-A --duration 3s --out " + out.string() + " " + args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.all;
    EXPECT_EQ(r.out.find("== gmb =="), std::string::npos) << args << ": nothing should run: " << r.out;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
}

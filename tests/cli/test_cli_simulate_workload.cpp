// `rayline simulate` with the path-tracing workload: runs from the scene profiles in
// scenes/, reports steady-state rays/s, prediction accuracy and the idle breakdown; a
// client sweep reports the peak; record + replay; bad profiles exit 2 naming file and
// field and leave nothing behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>
#include <unistd.h>

#include "cli_run.hpp"
#include "cli/trace_check.hpp"

using rayline::testing::rayline_cli;
namespace fs = std::filesystem;

namespace {
fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("rayline-ptcli-" + std::to_string(::getpid()) + "-" + name);
  fs::remove_all(p);
  return p;
}
const std::string kData = RAYLINE_TEST_DATA;
nlohmann::json metrics(const fs::path& dir) {
  std::ifstream in(dir / "metrics.json");
  return nlohmann::json::parse(in);
}
}  // namespace

TEST(CliSimulateWorkload, BoeingWithPredictionReportsAccuracyAndIdleBreakdown) {
  const fs::path out = scratch("boeing");
  const auto r = rayline_cli("simulate --workload boeing --clients 2 --prediction-depth 1 --duration 8s --no-progress --out " +
                             out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("steady state:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("true idle"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("prediction accuracy"), std::string::npos) << r.out;
  const auto m = metrics(out);
  EXPECT_EQ(m["path_trace"]["clients"], 2);
  EXPECT_EQ(m["path_trace"]["scene"], "boeing");
  EXPECT_GT(m["path_trace"]["rays"]["created"].get<double>(), 0);
  EXPECT_TRUE(m["path_trace"].contains("prediction"));
  fs::remove_all(out);
}

TEST(CliSimulateWorkload, MuseumRunsFromDefaults) {
  const fs::path out = scratch("museum");
  const auto r = rayline_cli("simulate --workload museum --duration 5s --no-progress --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(metrics(out)["path_trace"]["image"]["spp"], 128);
  // The result says how it was made: version and command line.
  EXPECT_FALSE(metrics(out)["rayline"]["version"].get<std::string>().empty());
  EXPECT_NE(metrics(out)["rayline"]["command"].get<std::string>().find("simulate --workload museum"), std::string::npos);
  fs::remove_all(out);
}

// Sec. 5.1 merges arriving queues into one queued job per (kind, block, memory device).
// Unbounded, 512 clients' first frames made one RayIntersect job of 86 GB, larger than any
// memory device of the cluster, and the run stalled at once (exit 1). A job now takes
// merged queues only while it fits where its kind can run (path_trace_workload.cpp).
TEST(CliSimulateWorkload, ManyClientsDoNotMergeIntoAJobNothingCanHold) {
  const fs::path out = scratch("museum-512");
  const auto r = rayline_cli("simulate --workload museum --clients 512 --duration 2s --no-timeline --no-progress --out " +
                             out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(r.err.find("could not be placed"), std::string::npos) << r.err;
  const auto m = metrics(out);
  EXPECT_FALSE(m.value("stalled", false)) << m.dump();
  fs::remove_all(out);
}

TEST(CliSimulateWorkload, ClientSweepReportsThePeak) {
  const fs::path out = scratch("sweep");
  const auto r = rayline_cli("simulate --workload " + kData + "/profiles/small.profile.json --platform paper-A --clients 1,2 "
                             "--duration 2s --no-progress --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("peak:"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(out / "clients-1" / "metrics.json"));
  EXPECT_TRUE(fs::exists(out / "clients-2" / "metrics.json"));
  fs::remove_all(out);
}

TEST(CliSimulateWorkload, RecordThenReplay) {
  const fs::path rec = scratch("rec"), rep = scratch("rep");
  const std::string base = "simulate --workload " + kData + "/profiles/small.profile.json --platform paper-A --duration 2s --no-progress ";
  ASSERT_EQ(rayline_cli(base + "--record-replay --out " + rec.string()).code, 0);
  ASSERT_TRUE(fs::exists(rec / "replay.log"));
  const auto r = rayline_cli(base + "--fidelity replay --replay " + (rec / "replay.log").string() + " --out " + rep.string());
  ASSERT_EQ(r.code, 0) << r.all;
  const auto m = metrics(rep);
  EXPECT_EQ(m["path_trace"]["fidelity"], "replay");
  EXPECT_EQ(m["path_trace"]["replay"]["fallback_rays"], 0);
  // Same seed and schedule: every piece of the recording is replayed as recorded.
  EXPECT_EQ(m["path_trace"]["rays"], metrics(rec)["path_trace"]["rays"]);
  fs::remove_all(rec);
  fs::remove_all(rep);
}

// --frames N: each client renders N frames and the run ends with the last one, its span the
// makespan (not --duration); every activity of the run ended by then.
TEST(CliSimulateWorkload, FramesEndTheRunAtTheLastDelivery) {
  const fs::path out = scratch("frames");
  const auto r = rayline_cli("simulate --workload " + kData + "/profiles/small.profile.json --platform paper-A --clients 2 "
                             "--frames 3 --duration 60s --no-progress --no-timeline --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  const auto m = metrics(out);
  EXPECT_EQ(m["path_trace"]["frames_per_client"], 3);
  EXPECT_EQ(m["path_trace"]["frames"]["delivered"], 6);
  EXPECT_EQ(m["path_trace"]["frames"]["exact"], 6);
  const double span = m["simulated_s"].get<double>();
  EXPECT_GT(span, 0.0);
  EXPECT_LT(span, 60.0);
  EXPECT_EQ(m["path_trace"]["rays"]["alive_at_end"], 0);
  std::ifstream jobs(out / "jobs.csv");
  std::string line, last_end;
  double latest = 0;
  std::getline(jobs, line);  // header: ...,actual_start,actual_end,state,created
  while (std::getline(jobs, line)) {
    std::vector<std::string> f;
    std::size_t at = 0;
    for (std::size_t c; (c = line.find(',', at)) != std::string::npos; at = c + 1) f.push_back(line.substr(at, c - at));
    f.push_back(line.substr(at));
    ASSERT_GE(f.size(), 13u) << line;
    if (!f[10].empty()) latest = std::max(latest, std::stod(f[10]));
  }
  EXPECT_NEAR(latest, span, 1e-6);  // the last activity is the last frame's AdditiveCompose
  fs::remove_all(out);
}

namespace {
// Scene blocks read from a disk into RAM, from a run's jobs.csv.
int scene_loads(const fs::path& dir) {
  std::ifstream jobs(dir / "jobs.csv");
  std::string line;
  int n = 0;
  while (std::getline(jobs, line)) n += line.find("disk->ram") != std::string::npos && line.find(",scene") != std::string::npos;
  return n;
}
}  // namespace

// --memory-budget sets every node's RAM, as a render's budget does: with room for 2 of the
// 8 blocks of 100 MB instead of 8 GiB, blocks are read again; a budget no block fits in
// stalls the run with the reason; a bad size exits 2.
TEST(CliSimulateWorkload, MemoryBudgetIsTheHostRam) {
  const fs::path full = scratch("ram-full"), small = scratch("ram-small"), bad = scratch("ram-bad");
  const std::string base = "simulate --workload " + kData + "/profiles/small.profile.json --platform paper-A --clients 2 "
                           "--frames 2 --duration 60s --no-progress --no-timeline ";
  ASSERT_EQ(rayline_cli(base + "--out " + full.string()).code, 0);
  const auto r = rayline_cli(base + "--memory-budget 300MB --out " + small.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(metrics(small)["host_memory_bytes"], 300000000u);
  EXPECT_FALSE(metrics(full).contains("host_memory_bytes"));
  EXPECT_EQ(metrics(small)["path_trace"]["frames"]["delivered"], 4);
  EXPECT_EQ(scene_loads(full), 8);  // each block once
  EXPECT_GT(scene_loads(small), 8);
  const auto stall = rayline_cli(base + "--memory-budget 50MB --out " + bad.string());
  EXPECT_EQ(stall.code, 1) << stall.all;
  EXPECT_NE(stall.err.find("room for input 'scene"), std::string::npos) << stall.err;
  // The clients' framebuffers (64 x 48 x 16 B each) stay on the first host memory: reported,
  // and named in a note once they take half of it.
  const auto fb = metrics(small)["path_trace"]["client_framebuffers"];
  EXPECT_EQ(fb["memory"], "A0.ram");
  EXPECT_EQ(fb["bytes"], 2u * 64u * 48u * 16u);
  EXPECT_EQ(stall.out.find("note: the clients' framebuffers"), std::string::npos) << stall.out;
  const auto crowded = rayline_cli(base + "--memory-budget 150kB --out " + bad.string() + "-fb");
  EXPECT_EQ(crowded.code, 1) << crowded.all;
  EXPECT_NE(crowded.out.find("note: the clients' framebuffers (96.0 KiB) take 66% of A0.ram"), std::string::npos)
      << crowded.out;
  fs::remove_all(bad.string() + "-fb");
  for (const std::string v : {"0", "lots", "-5MB"}) {
    const auto b = rayline_cli(base + "--memory-budget " + v + " --out " + bad.string() + "-2");
    EXPECT_EQ(b.code, 2) << v << ": " << b.all;
    EXPECT_NE(b.err.find("--memory-budget"), std::string::npos) << b.err;
  }
  fs::remove_all(full);
  fs::remove_all(small);
  fs::remove_all(bad);
}

// A replay log that does not fit the profile (here a shading outcome category that does
// not exist) is refused before the simulation starts: exit 2, file and line named, no
// output. It used to fail mid-run and, through SimGrid, crash.
TEST(CliSimulateWorkload, DamagedReplayLogExits2NamingFileAndLine) {
  const fs::path rec = scratch("rec-bad"), out = scratch("rep-bad");
  const std::string base = "simulate --workload " + kData + "/profiles/small.profile.json --platform paper-A --duration 1s --no-progress ";
  ASSERT_EQ(rayline_cli(base + "--record-replay --no-timeline --out " + rec.string()).code, 0);
  std::vector<std::string> lines;
  {
    std::ifstream in(rec / "replay.log");
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  std::size_t shade = 0;
  while (shade < lines.size() && !lines[shade].starts_with("shade ")) ++shade;
  ASSERT_LT(shade, lines.size());
  const std::size_t colon = lines[shade].rfind(':'), space = lines[shade].rfind(' ');
  lines[shade] = lines[shade].substr(0, space + 1) + "7" + lines[shade].substr(colon);
  const fs::path bad = rec / "damaged.log";
  {
    std::ofstream o(bad);
    for (const auto& l : lines) o << l << "\n";
  }
  const auto r = rayline_cli(base + "--fidelity replay --replay " + bad.string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find(bad.string()), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("line " + std::to_string(shade + 1)), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("category 7"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  fs::remove_all(rec);
}

TEST(CliSimulateWorkload, BadProfilesExit2NamingFileAndFieldAndWriteNothing) {
  const struct {
    const char* file;
    const char* field;
  } cases[] = {{"bad-block-count.profile.json", "block_count"},
               {"bad-probabilities.profile.json", "blocks[3].neighbours"},
               {"bad-negative-size.profile.json", "blocks[2].bytes"},
               {"bad-unknown-neighbour.profile.json", "blocks[1].neighbours[1]"}};
  for (const auto& c : cases) {
    const fs::path out = scratch("bad");
    const auto r = rayline_cli("simulate --workload " + kData + "/profiles/" + c.file + " --no-progress --out " + out.string());
    EXPECT_EQ(r.code, 2) << c.file << ": " << r.all;
    EXPECT_NE(r.err.find(c.file), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.field), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

TEST(CliSimulateWorkload, BadFlagsExit2) {
  const fs::path out = scratch("flags");
  EXPECT_EQ(rayline_cli("simulate --workload boeing --fidelity exact --no-progress --out " + out.string()).code, 2);
  EXPECT_EQ(rayline_cli("simulate --workload boeing --fidelity replay --no-progress --out " + out.string()).code, 2);
  EXPECT_EQ(rayline_cli("simulate --workload boeing --clients 0 --no-progress --out " + out.string()).code, 2);
  EXPECT_EQ(rayline_cli("simulate --clients 4 --no-progress --out " + out.string()).code, 2);  // ray-stream has no clients
  // Every path-tracing flag is refused for a ray stream (--warmup and the on/off switches
  // used to be ignored without a word), and the message names each one given.
  for (const std::string args : {"--warmup 5s", "--merge-planned off", "--retime-merged off", "--cancel-failed off",
                                 "--prediction-depth 1", "--fidelity analytic", "--record-replay", "--frames 1"}) {
    const auto r = rayline_cli("simulate --duration 2s --no-progress --out " + out.string() + " " + args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.all;
    EXPECT_NE(r.err.find(args.substr(0, args.find(' ')) + " applies only to path tracing"), std::string::npos) << r.err;
  }
  const auto two = rayline_cli("simulate --warmup 1s --clients 2 --no-progress --out " + out.string());
  EXPECT_EQ(two.code, 2) << two.all;
  EXPECT_NE(two.err.find("--clients, --warmup apply only to path tracing"), std::string::npos) << two.err;
  EXPECT_EQ(rayline_cli("compare --schedulers gmb --warmup 1s --out " + out.string()).code, 2);
  const auto blocks = rayline_cli("simulate --workload museum --blocks 50 --no-progress --out " + out.string());
  EXPECT_EQ(blocks.code, 2) << blocks.all;  // the profile has its own 65 blocks
  EXPECT_NE(blocks.err.find("--blocks: applies only to the ray stream"), std::string::npos) << blocks.err;
  EXPECT_FALSE(fs::exists(out));
}

// docs/faults.md: node B of the paper cluster off at 10 s, on SimGrid. The run goes on to
// its end on the nodes left, reports the fault (devices lost, work aborted and queued
// again, throughput before and after) and keeps its ray tally whole (lost rays counted).
TEST(CliSimulateWorkload, NodeOffAtTenSecondsIsReportedAndTheRunGoesOn) {
  const fs::path out = scratch("fail");
  const auto r = rayline_cli("simulate --workload museum --clients 4 --duration 20s --fail B@10s --no-progress --out " +
                             out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("faults: 1 applied"), std::string::npos) << r.out;
  const auto m = metrics(out);
  const auto& f = m["faults"]["applied"].at(0);
  EXPECT_EQ(f["fail"], "B@10s");
  EXPECT_DOUBLE_EQ(f["at_s"].get<double>(), 10.0);
  EXPECT_GT(f["lost"].size(), 3u);
  EXPECT_GT(f["jobs_queued_again"].get<double>() + f["jobs_lost"].get<double>(), 0);
  EXPECT_GT(f["rays_per_second_after"].get<double>(), 0);
  const auto& rays = m["path_trace"]["rays"];
  EXPECT_LE(rays["ended"].get<double>() + rays["lost"].get<double>(), rays["created"].get<double>());
  EXPECT_TRUE(m["faults"]["not_reached"].empty());
  fs::remove_all(out);
  // A device the platform does not have: exit 2 naming the flag, nothing written.
  const auto bad = rayline_cli("simulate --fail Z9@1s --no-progress --out " + out.string());
  EXPECT_EQ(bad.code, 2) << bad.all;
  EXPECT_NE(bad.err.find("--fail"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(out));
}

// --clients auto: the sweep doubles the clients until two counts in a row gain no more than
// 2 % (sim/peak_search.hpp) and reports the peak (compare's sweeps: test_cli_compare_peak).
TEST(CliSimulateWorkload, ClientsAutoFindsThePeakItself) {
  const fs::path out = scratch("auto");
  const auto r = rayline_cli("simulate --workload museum --clients auto --duration 3s --no-progress --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("peak:"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(out / "clients-1" / "metrics.json"));
  EXPECT_TRUE(fs::exists(out / "clients-2" / "metrics.json"));
  EXPECT_TRUE(fs::exists(out / "clients-4" / "metrics.json")) << "at least three points: two must fail to gain";
  fs::remove_all(out);
}

// timeline.json opens in Perfetto without losing slices: no two complete events overlap
// on one track (planned and actual on tracks of their own, each split into lanes where
// its slices overlap). A 10 s museum run had 127 of 986 slices dropped before.
TEST(CliSimulateWorkload, TimelineHasNoOverlappingSlicesOnAnyTrack) {
  const fs::path out = scratch("trace");
  const auto r = rayline_cli("simulate --workload museum --clients 4 --duration 10s --no-progress --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  std::ifstream in(out / "timeline.json");
  const auto c = rayline::testing::check_trace(nlohmann::json::parse(in));
  EXPECT_GT(c.slices, 500u);
  EXPECT_EQ(c.overlaps, 0u) << c.slices << " slices on " << c.tracks << " tracks";
  fs::remove_all(out);
}

// A run too short for its first ray jobs said "ok" with 0 rays/s. It now says why (the
// longest unfinished E-job and when it would end) and what to change; compare marks the row
// "no rays ended" (the run completed: exit 0) and points at the reason.
TEST(CliSimulateWorkload, ARunThatDeliversNothingSaysWhy) {
  const fs::path out = scratch("nothing");
  const auto r = rayline_cli("simulate --platform paper-2A --workload museum --duration 4s --no-progress --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("note: no ray ended after the warm-up"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--duration of at least"), std::string::npos) << r.out;
  EXPECT_TRUE(metrics(out)["path_trace"].contains("nothing_delivered"));
  fs::remove_all(out);
  const auto c = rayline_cli("compare --platform paper-2A --workload museum --duration 4s --schedulers gmb,budge --out " +
                             out.string());
  ASSERT_EQ(c.code, 0) << c.all;
  EXPECT_NE(c.out.find("no rays ended"), std::string::npos) << c.out;
  fs::remove_all(out);
}

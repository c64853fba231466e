// `rayline render` / `rayline calibrate`: outputs, metrics, memory bound, and
// bad inputs (exit 2, a clear message naming file and field, no half-written image).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "cli/cli_run.hpp"
#include "cli/scratch_test.hpp"
#include "cli/trace_check.hpp"

namespace fs = std::filesystem;
using rayline::testing::rayline_cli;
using rayline::testing::rayline_limited;

namespace {
class CliRender : public rayline::testing::ScratchTest {
 protected:
  nlohmann::json metrics(const std::string& image_stem) const {
    std::ifstream in(path(image_stem + ".metrics.json"));
    return nlohmann::json::parse(in);
  }
  // A small partition of the built-in scene, and an existing good image to protect.
  void blocks(int n) {
    const auto r = rayline_cli("partition -q --blocks " + std::to_string(n) + " --out " + path("blocks"));
    ASSERT_EQ(r.code, 0) << r.all;
  }
};

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
}  // namespace

TEST_F(CliRender, SmallRenderWritesEveryOutput) {
  const auto r = rayline_cli("render --resolution 32x24 --spp 2 --blocks 6 --out " + path("img.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  for (const char* s : {"img.exr", "img.png", "img.metrics.json", "img.timeline.json", "img.jobs.csv"})
    EXPECT_TRUE(fs::exists(path(s))) << s;
  const auto m = metrics("img");
  EXPECT_EQ(m.at("resolution")[0], 32);
  EXPECT_EQ(m.at("spp"), 2);
  EXPECT_EQ(m.at("blocks"), 6);
  EXPECT_NE(m.at("rayline").at("command").get<std::string>().find("render --resolution 32x24"), std::string::npos);
  EXPECT_TRUE(m.at("rays").at("conserved").get<bool>());
  EXPECT_GT(m.at("rays_per_second").get<double>(), 0);
  EXPECT_EQ(m.at("io").at("unplanned_loads"), 0);
  EXPECT_EQ(m.at("devices").size(), m.at("threads").get<std::size_t>());
  EXPECT_TRUE(m.at("batching").at("continue_in_cell").get<bool>());
  EXPECT_FALSE(m.at("batching").at("camera_jobs").get<bool>()) << "camera jobs only with one block";
  // The timeline opens in Perfetto: Chrome trace JSON, no two slices overlapping on a track
  // (Perfetto would drop one).
  std::ifstream tl(path("img.timeline.json"));
  const auto t = nlohmann::json::parse(tl);
  EXPECT_TRUE(t.contains("traceEvents"));
  const auto c = rayline::testing::check_trace(t);
  EXPECT_GT(c.slices, 0u);
  EXPECT_EQ(c.overlaps, 0u);
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos) << e.path();
}

TEST_F(CliRender, MemoryStaysWithinBudgetPlusDocumentedOverhead) {
  // A 300 k-triangle museum-like scene, rendered with a quarter of its blocks in RAM.
  auto r = rayline_cli("generate museum-like --triangles 300000 --out " + path("museum.ply"));
  ASSERT_EQ(r.code, 0) << r.all;
  r = rayline_cli("partition -q --scene " + path("museum.ply") + " --blocks 16 --out " + path("blocks"));
  ASSERT_EQ(r.code, 0) << r.all;
  r = rayline_cli("render -q --scene " + path("museum.ply") + " --blocks-dir " + path("blocks") +
                  " --resolution 64x64 --spp 1 --out " + path("in.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  const auto in_core = metrics("in");
  const auto scene_bytes = in_core.at("memory").at("scene_block_bytes").get<std::uint64_t>();
  const std::uint64_t budget = scene_bytes / 4;
  for (const std::string loaders : {"1", "2"}) {  // one or two loads in flight
    const std::string name = "b" + loaders;
    r = rayline_cli("render -q --scene " + path("museum.ply") + " --blocks-dir " + path("blocks") +
                    " --resolution 64x64 --spp 1 --loaders " + loaders + " --memory-budget " + std::to_string(budget) + "B" +
                    " --out " + path(name + ".exr"));
    ASSERT_EQ(r.code, 0) << r.all;
    const auto m = metrics(name).at("memory");
    EXPECT_LE(m.at("peak_resident_block_bytes").get<std::uint64_t>(), budget);
#if !defined(__SANITIZE_ADDRESS__)  // ASan's quarantine keeps freed blocks resident: RSS says nothing there
    const auto grown = m.at("peak_rss_bytes").get<double>() - m.at("rss_at_start_bytes").get<double>();
    EXPECT_LE(grown, double(budget + m.at("overhead_bound_bytes").get<std::uint64_t>()))
        << "RSS grew by " << grown << " bytes; budget " << budget << "; loaders " << loaders;
#endif
    EXPECT_LE(m.at("worst_footprint_ratio").get<double>(), 1.0) << "a block used more RAM than the plan charged";
    const auto io = metrics(name).at("io");
    EXPECT_GT(io.at("evictions").get<int>(), 0);
    EXPECT_EQ(io.at("loaders").get<int>(), std::stoi(loaders));
    // I/O-bound time (no E-job running, between the first and the last load) is part of
    // the run, and the channel's share of it is a fraction.
    EXPECT_GT(io.at("io_bound_seconds").get<double>(), 0.0);
    EXPECT_LE(io.at("io_bound_seconds").get<double>(), metrics(name).at("seconds").get<double>());
    EXPECT_GT(io.at("disk_busy_when_io_bound").get<double>(), 0.0);
    EXPECT_LE(io.at("disk_busy_when_io_bound").get<double>(), 1.0 + 1e-12);
  }
#if !defined(__SANITIZE_ADDRESS__)
  // The same bound at every budget from 10 % to 100 %, with the blocks `render` picks.
  for (const int percent : {10, 50, 100}) {
    const std::string name = "p" + std::to_string(percent);
    const std::uint64_t b = scene_bytes * std::uint64_t(percent) / 100;
    r = rayline_cli("render -q --scene " + path("museum.ply") + " --resolution 64x64 --spp 1 --memory-budget " +
                    std::to_string(b) + "B --out " + path(name + ".exr"));
    ASSERT_EQ(r.code, 0) << r.all;
    const auto m = metrics(name).at("memory");
    const auto grown = m.at("peak_rss_bytes").get<double>() - m.at("rss_at_start_bytes").get<double>();
    EXPECT_LE(grown, double(b + m.at("overhead_bound_bytes").get<std::uint64_t>()))
        << "RSS grew by " << grown << " bytes; budget " << b << " (" << percent << " %)";
    EXPECT_LE(m.at("peak_resident_block_bytes").get<std::uint64_t>(), b);
  }
#endif
  // In core with one block the only T-job is its load, during which no E-job can run: the
  // whole window is I/O-bound and the channel busy all of it.
  r = rayline_cli("partition -q --scene " + path("museum.ply") + " --blocks 1 --out " + path("one"));
  ASSERT_EQ(r.code, 0) << r.all;
  r = rayline_cli("render -q --scene " + path("museum.ply") + " --blocks-dir " + path("one") +
                  " --resolution 16x16 --spp 1 --out " + path("one.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  const auto one = metrics("one").at("io");
  EXPECT_GT(one.at("io_bound_seconds").get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(one.at("disk_busy_when_io_bound").get<double>(), 1.0);
}

TEST_F(CliRender, PathsInFlightAutoAndExplicit) {
  blocks(4);
  const std::string args = "render -q --resolution 16x16 --spp 2 --blocks-dir " + path("blocks") + " ";
  // Auto under a budget: every path of the frame fits next to the largest block here.
  auto r = rayline_cli(args + "--memory-budget 64MiB --out " + path("auto.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(metrics("auto").at("memory").at("paths_in_flight_cap").get<int>(), 16 * 16 * 2);
  r = rayline_cli(args + "--memory-budget 64MiB --paths 100 --out " + path("explicit.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(metrics("explicit").at("memory").at("paths_in_flight_cap").get<int>(), 100);
  r = rayline_cli(args + "--paths 10 --out " + path("bad.exr"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("paths"), std::string::npos) << r.err;
  r = rayline_cli(args + "--read-ahead maybe --out " + path("bad.exr"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("read-ahead"), std::string::npos) << r.err;
  r = rayline_cli(args + "--aging soon --out " + path("bad.exr"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--aging"), std::string::npos) << r.err;
  // --aging reaches the scheduler.
  r = rayline_cli(args + "--aging adaptive --out " + path("adaptive.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(metrics("adaptive").at("scheduler_parameters").get<std::string>().find("adaptive_aging=1"), std::string::npos);
  r = rayline_cli(args + "--aging off --out " + path("off.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(metrics("off").at("scheduler_parameters").get<std::string>().find("aging=off"), std::string::npos);
  EXPECT_FALSE(fs::exists(path("bad.exr")));
}

// --out names the image's format by its extension: .png writes the 8-bit image alone (no
// OpenEXR, no second preview), with the metrics, timeline and jobs CSV next to it.
TEST_F(CliRender, PngOutWritesAPngAndItsCompanions) {
  const auto r = rayline_cli("render -q --resolution 16x12 --spp 1 --blocks 2 --out " + path("img.PNG"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(slurp(path("img.PNG")).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  for (const char* s : {"img.metrics.json", "img.timeline.json", "img.jobs.csv"}) EXPECT_TRUE(fs::exists(path(s))) << s;
  for (const char* s : {"img.exr", "img.png"}) EXPECT_FALSE(fs::exists(path(s))) << s;
  EXPECT_EQ(metrics("img").at("resolution")[0], 16);
  const auto v = rayline_cli("render --resolution 16x12 --spp 1 --blocks 2 --out " + path("v.png"));
  ASSERT_EQ(v.code, 0) << v.all;
  EXPECT_NE(v.out.find("wrote " + path("v.png") + ", " + path("v.metrics.json")), std::string::npos) << v.out;
}

TEST_F(CliRender, BadInputsExitTwoAndKeepTheGoodImage) {
  blocks(4);
  auto r = rayline_cli("render -q --resolution 16x16 --spp 1 --blocks-dir " + path("blocks") + " --out " + path("good.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  const std::string good = slurp(path("good.exr"));
  const std::string args = "render -q --resolution 16x16 --spp 1 --out " + path("good.exr") + " ";

  // Budget smaller than the largest block.
  r = rayline_cli(args + "--blocks-dir " + path("blocks") + " --memory-budget 1KiB");
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("memory-budget"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("largest block"), std::string::npos) << r.err;

  // Corrupted payload (one flipped byte): found when the block is loaded.
  fs::copy(path("blocks"), path("corrupt"), fs::copy_options::recursive);
  {
    std::fstream f(path("corrupt/block_00001.rlb"), std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(200);
    char c = 0;
    f.read(&c, 1);
    c ^= 0x5a;
    f.seekp(200);
    f.write(&c, 1);
  }
  r = rayline_cli(args + "--blocks-dir " + path("corrupt"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("block_00001.rlb"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("payload_crc32"), std::string::npos) << r.err;

  // Truncated and missing block files: found before anything runs.
  fs::copy(path("blocks"), path("short"), fs::copy_options::recursive);
  fs::resize_file(path("short/block_00002.rlb"), fs::file_size(path("short/block_00002.rlb")) - 40);
  r = rayline_cli(args + "--blocks-dir " + path("short"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("block_00002.rlb"), std::string::npos) << r.err;
  fs::remove(path("short/block_00003.rlb"));
  fs::resize_file(path("short/block_00002.rlb"), 0);
  r = rayline_cli(args + "--blocks-dir " + path("short"));
  EXPECT_EQ(r.code, 2) << r.all;

  // Unknown scene field.
  {
    std::ofstream s(path("bad.json"));
    s << R"({"version": 1, "materials": {"m": {"albedo": [0.5, 0.5, 0.5]}},
             "meshes": [{"name": "c", "generator": "cornell", "triangles": 1000, "material": "m"}],
             "cameras": {"c": {"position": [0, 0, 3], "look_at": [0, 0, 0]}}, "colour": 3})";
  }
  r = rayline_cli(args + "--scene " + path("bad.json"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("bad.json"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("colour"), std::string::npos) << r.err;

  // A folder where the scene file belongs.
  fs::create_directories(path("folder.json"));
  r = rayline_cli(args + "--scene " + path("folder.json"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("is a folder"), std::string::npos) << r.err;

  // Unwritable output path (a file where a folder should be), bad resolution, bad flags.
  { std::ofstream f(path("plain")); }
  r = rayline_cli("render -q --resolution 16x16 --spp 1 --out " + path("plain/x.exr"));
  EXPECT_EQ(r.code, 2) << r.all;
  r = rayline_cli(args + "--resolution 16by16");
  EXPECT_EQ(r.code, 2) << r.all;
  r = rayline_cli(args + "--scheduler fastest");
  EXPECT_EQ(r.code, 2) << r.all;
  // NaN used to pass CLI11's PositiveNumber; a bare number has no unit.
  for (const std::string h : {"nan", "inf", "0", "-1", "2", "0s", "-1s", "nans", "1e300s"}) {
    r = rayline_cli(args + "--horizon " + h);
    EXPECT_EQ(r.code, 2) << h << ": " << r.all;
    EXPECT_NE(r.err.find("--horizon"), std::string::npos) << r.err;
    EXPECT_LT(r.err.size(), 200u) << "a short message, not a 300-digit number: " << r.err;
  }
  for (const char* out : {"img.jpg", "img", "img.exr.tmp"}) {
    r = rayline_cli("render -q --out " + path(out));
    EXPECT_EQ(r.code, 2) << out << ": " << r.all;
    EXPECT_NE(r.err.find("use a name ending in .exr"), std::string::npos) << r.err;
  }
  // Messages name the flag the user gave, once: a new partition's folder is --blocks-dir
  // (not partition's --out), too many blocks is --blocks (the buffer bound is not a render
  // flag), and a flag is not repeated as a field ("--paths: paths:").
  r = rayline_cli(args + "--blocks-dir " + path("plain"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--blocks-dir: exists and is not a folder"), std::string::npos) << r.err;
  r = rayline_cli(args + "--blocks 1048576 --blocks-dir " + path("many"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--blocks: too many"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("many")));
  for (const std::string flag : {"--paths 8", "--bvh-quality best", "--gpu-memory-budget 0", "--memory-budget 1KiB"}) {
    r = rayline_cli(args + flag);
    EXPECT_EQ(r.code, 2) << flag << ": " << r.all;
    const std::string name = flag.substr(2, flag.find(' ') - 2);
    EXPECT_EQ(r.err.find("--" + name + ": " + name + ":"), std::string::npos) << r.err;
  }

  EXPECT_EQ(slurp(path("good.exr")), good) << "a failed run must leave the good image in place";
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos) << e.path();
}

// A disk that fills up while the outputs are written (here a file size limit, which fails
// the write with EFBIG as a full disk fails it with ENOSPC): the EXR was already in place
// when a later file failed, the rest never came, and the run exited 2 as for bad input.
// Now every output is written first and all are renamed together, or none: exit 1 naming
// the file, the earlier run's outputs untouched, no temporary left.
TEST_F(CliRender, AFullDiskPublishesNoOutputAndKeepsTheEarlierOnes) {
  blocks(2);
  const std::vector<std::string> names = {"img.exr", "img.png", "img.metrics.json", "img.timeline.json", "img.jobs.csv"};
  const std::string args = "-q --resolution 16x16 --spp 16 --seed 7 --blocks-dir " + path("blocks") + " --out " + path("img.exr");
  auto r = rayline_cli("render " + args);
  ASSERT_EQ(r.code, 0) << r.all;
  std::vector<std::string> before;
  for (const std::string& n : names) before.push_back(slurp(path(n)));
  // A limit that lets the image through and stops the first later, larger file (in the
  // order written: image, preview, metrics, timeline, jobs CSV).
  std::size_t largest = before[0].size(), failing = 0;
  for (std::size_t i = 1; i < names.size() && !failing; ++i) {
    if (before[i].size() > largest + largest / 20) failing = i;
    else largest = std::max(largest, before[i].size());
  }
  ASSERT_GT(failing, 0u) << "no output after the image is larger than it";
  // Near the largest file that must pass: the timeline and jobs files vary in size from run
  // to run (their activities depend on measured times), the image with the seed does not.
  const rlim_t limit = largest + (before[failing].size() - largest) / 4;
  std::vector<std::string> argv = {"render", "-q", "--resolution", "16x16", "--spp", "16", "--seed", "7",
                                   "--blocks-dir", path("blocks"), "--out", path("img.exr")};
  r = rayline_limited(RLIMIT_FSIZE, limit, argv);
  EXPECT_EQ(r.code, 1) << r.all;
  EXPECT_NE(r.err.find("cannot write " + path(names[failing]) + ": File too large"), std::string::npos) << r.err;
  for (std::size_t i = 0; i < names.size(); ++i)
    EXPECT_TRUE(slurp(path(names[i])) == before[i]) << names[i] << " was replaced by the failed run";
  for (const auto& e : fs::directory_iterator(dir_)) {
    const std::string n = e.path().filename().string();
    EXPECT_TRUE(n == "blocks" || std::find(names.begin(), names.end(), n) != names.end()) << "left behind: " << n;
  }
  // Into a fresh name nothing appears at all.
  argv.back() = path("new.exr");
  r = rayline_limited(RLIMIT_FSIZE, limit, argv);
  EXPECT_EQ(r.code, 1) << r.all;
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_FALSE(e.path().filename().string().starts_with("new.")) << "left behind: " << e.path();
}

// More worker threads than the address space allows (-j 1000 under ulimit -v): the threads
// already started were destroyed joinable, and std::terminate ended the run (SIGABRT).
TEST_F(CliRender, ThreadsTheSystemCannotStartAreAFailedRunNotACrash) {
  blocks(2);
  // 1000 compute devices and the disk channel: 1001 threads of 8 MiB stacks in 2 GiB.
  const auto r = rayline_limited(RLIMIT_AS, rlim_t(2) << 30,
                                 {"render", "-q", "--gpu", "none", "--resolution", "16x16", "--spp", "1", "-j", "1000",
                                  "--blocks-dir", path("blocks"), "--out", path("img.exr")});
  if (r.err.find("Sanitizer") != std::string::npos) GTEST_SKIP() << "a sanitizer's shadow memory needs more address space";
  EXPECT_EQ(r.code, 1) << r.all;
  EXPECT_NE(r.err.find("rayline: error: cannot start 1001 worker threads"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("terminate"), std::string::npos) << r.err;
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_FALSE(e.path().filename().string().starts_with("img.")) << "left behind: " << e.path();
}

TEST_F(CliRender, CalibrateWritesAPlatformTheRendererReads) {
  auto r = rayline_cli("calibrate -q --resolution 48x48 --spp 2 --blocks 8 --out " + path("me.json"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("Eq. 1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Eq. 2"), std::string::npos) << r.out;
  // Each fit's error on the measured time, its median and worst (sched/core/fit_errors.hpp), all
  // defined: the loads, the control loop's latency, RayIntersect and ShadowIntersect.
  std::size_t fits = 0;
  for (std::size_t at = 0; (at = r.out.find("% of the measured time (median", at)) != std::string::npos; ++at) ++fits;
  EXPECT_EQ(fits, 4u) << r.out;
  EXPECT_NE(r.out.find("control loop after a finished job"), std::string::npos) << r.out;
  // Two passes by default: the fitted renders were planned on a first render's fit.
  EXPECT_NE(r.out.find("of 3, planned on a first render's fit"), std::string::npos) << r.out;
  std::ifstream platform(path("me.json"));
  const auto p = nlohmann::json::parse(platform);
  ASSERT_TRUE(p.contains("control_loop")) << p.dump(2);
  EXPECT_GE(p.at("control_loop").at("per_exec_second").get<double>(), 0.0);
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
  r = rayline_cli("platform check " + path("me.json"));
  ASSERT_EQ(r.code, 0) << r.all;
  r = rayline_cli("render -q --resolution 16x16 --spp 1 --platform " + path("me.json") + " --out " + path("p.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(metrics("p").at("platform"), path("me.json"));
}

// One pass: the renders fitted are planned on the default platform.
TEST_F(CliRender, CalibrateInOnePassFitsRendersPlannedOnDefaults) {
  auto r = rayline_cli("calibrate -q --passes 1 --repeats 1 --resolution 32x32 --spp 1 --blocks 8 --out " + path("one.json"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("median wall time"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("planned on a first render's fit"), std::string::npos) << r.out;
  r = rayline_cli("calibrate -q --passes 3 --out " + path("bad.json"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--passes"), std::string::npos) << r.err;
}

// calibration measures the GPU too (its jobs' Eq. 2, the RAM->GPU channel's
// Eq. 1) and writes it into the platform file; the renderer drives that GPU from it.
TEST_F(CliRender, CalibrateCoversTheGpu) {
  auto d = rayline_cli("devices --json --gpu none");
  ASSERT_EQ(d.code, 0) << d.all;
  const auto devs = nlohmann::json::parse(d.out)["vulkan"];
  if (devs.empty()) GTEST_SKIP() << "no Vulkan device here";
  const std::string gpu = std::to_string(devs[0]["index"].get<int>());
  auto r = rayline_cli("calibrate -q --gpu " + gpu + " --resolution 48x48 --spp 2 --blocks 8 --out " + path("gpu.json"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("RAM->GPU channel"), std::string::npos) << r.out;
  const auto platform = nlohmann::json::parse(slurp(path("gpu.json")));
  bool gpu_compute = false, pcie = false;
  for (const auto& c : platform["node_types"]["W"]["compute"])
    gpu_compute = gpu_compute || (c["kind"] == "gpu" && c["timing"].contains("RayIntersect"));
  for (const auto& c : platform["node_types"]["W"]["channels"]) pcie = pcie || c["kind"] == "pcie";
  EXPECT_TRUE(gpu_compute) << platform.dump(2);
  EXPECT_TRUE(pcie) << platform.dump(2);
  r = rayline_cli("render -q --gpu " + gpu + " --resolution 16x16 --spp 1 --platform " + path("gpu.json") + " --out " +
                  path("g.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(metrics("g").at("gpu").at("status"), "used");
  // The same platform without the GPU: the CPU devices alone, same image.
  r = rayline_cli("render -q --gpu none --resolution 16x16 --spp 1 --platform " + path("gpu.json") + " --out " +
                  path("c.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(metrics("c").at("gpu").at("device"), "");
}

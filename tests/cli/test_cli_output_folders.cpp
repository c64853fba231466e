// Results folders and output files never take the user's data with them (docs/architecture.md, "Bad
// input": nothing lost; common/output_folder.hpp). `simulate --out DIR` used to delete DIR
// whatever it held, and `--out .` emptied the current folder and then lost the results too.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/cli_run.hpp"
#include "cli/scratch_test.hpp"

namespace fs = std::filesystem;
using rayline::testing::rayline_cli;
using rayline::testing::rayline_limited;

namespace {
class OutputFolders : public rayline::testing::ScratchTest {
 protected:
  void write(const std::string& n, const std::string& text) const {
    fs::create_directories(fs::path(path(n)).parent_path());
    std::ofstream(path(n)) << text;
  }
  std::string read(const std::string& n) const {
    std::ifstream in(path(n));
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  // Nothing but `names` in the scratch folder: no *.partial.*, *.old.* or *.tmp.* left.
  void expect_only(std::initializer_list<const char*> names) const {
    std::vector<std::string> got;
    for (const auto& e : fs::directory_iterator(dir_)) got.push_back(e.path().filename().string());
    std::sort(got.begin(), got.end());
    std::vector<std::string> want(names.begin(), names.end());
    std::sort(want.begin(), want.end());
    EXPECT_EQ(got, want);
  }
};
const std::string kSim = "simulate --platform paper-A --duration 1s --no-progress ";
}  // namespace

TEST_F(OutputFolders, SimulateNeverReplacesAFolderHoldingTheUsersFiles) {
  write("home/thesis.tex", "precious");
  auto r = rayline_cli(kSim + "--out " + path("home"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--out: folder holds 'thesis.tex'"), std::string::npos) << r.err;
  EXPECT_EQ(read("home/thesis.tex"), "precious");
  EXPECT_FALSE(fs::exists(path("home/metrics.json")));
  // A file named as the folder is not replaced either.
  write("afile", "precious");
  r = rayline_cli(kSim + "--out " + path("afile"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("exists and is not a folder"), std::string::npos) << r.err;
  EXPECT_EQ(read("afile"), "precious");
  r = rayline_cli(kSim + "--out ''");
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--out: missing output folder"), std::string::npos) << r.err;
  // The current folder, or one above it, would take the current folder with them. Run from
  // inside the scratch folder, so that a regression could only ever empty that (the root
  // is checked in tests/sched/test_output_folder.cpp, which never deletes anything).
  write("a/b/canary", "precious");
  const fs::path before = fs::current_path();
  fs::current_path(path("a/b"));
  for (const std::string p : {".", "..", "./", "../b"}) {
    r = rayline_cli(kSim + "--out " + p);
    EXPECT_EQ(r.code, 2) << p << ": " << r.all;
    EXPECT_NE(r.err.find("is the current folder or holds it"), std::string::npos) << r.err;
  }
  fs::current_path(before);
  EXPECT_EQ(read("a/b/canary"), "precious");
  expect_only({"home", "afile", "a"});
}

TEST_F(OutputFolders, SimulateReplacesItsOwnEarlierResults) {
  const std::string out = path("run");
  ASSERT_EQ(rayline_cli(kSim + "--paje --out " + out).code, 0);
  ASSERT_TRUE(fs::exists(path("run/simgrid.trace")));
  // A trailing '/' names the same folder (the partial folder goes beside it, not inside).
  const auto again = rayline_cli(kSim + "--out " + out + "/");
  ASSERT_EQ(again.code, 0) << again.all;
  EXPECT_TRUE(fs::exists(path("run/metrics.json")));
  EXPECT_FALSE(fs::exists(path("run/simgrid.trace"))) << "the earlier run's files are replaced, not merged";
  // Once the user adds a file, the folder is theirs.
  write("run/notes.txt", "mine");
  const auto r = rayline_cli(kSim + "--out " + out);
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("'notes.txt'"), std::string::npos) << r.err;
  EXPECT_EQ(read("run/notes.txt"), "mine");
  // Through a symbolic link, the folder it points to is the one replaced.
  fs::create_directory(path("real"));
  fs::create_directory_symlink(path("real"), path("link"));
  ASSERT_EQ(rayline_cli(kSim + "--out " + path("link")).code, 0);
  EXPECT_TRUE(fs::is_symlink(path("link")));
  EXPECT_TRUE(fs::exists(path("real/metrics.json")));
  expect_only({"run", "real", "link"});
}

// `rayline report` writes its page into the run's folder: the next run still replaces
// the folder, and the page of the run it replaces goes with it.
TEST_F(OutputFolders, ARunsReportPageDoesNotKeepTheFolderFromBeingReplaced) {
  ASSERT_EQ(rayline_cli(kSim + "--out " + path("run")).code, 0);
  ASSERT_EQ(rayline_cli("report " + path("run")).code, 0);
  ASSERT_TRUE(fs::exists(path("run/report.html")));
  auto r = rayline_cli(kSim + "--out " + path("run"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_FALSE(fs::exists(path("run/report.html")));
  const std::string cmp = "compare --platform paper-A --duration 1s --schedulers gmb,budge --out " + path("cmp");
  ASSERT_EQ(rayline_cli(cmp).code, 0);
  ASSERT_EQ(rayline_cli("report " + path("cmp")).code, 0);
  ASSERT_TRUE(fs::exists(path("cmp/report.html")));
  r = rayline_cli(cmp);
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_FALSE(fs::exists(path("cmp/report.html")));
  const std::string sweep = "simulate --platform paper-A --workload museum --clients 1,2 --duration 1s --no-progress --out " + path("sweep");
  ASSERT_EQ(rayline_cli(sweep).code, 0);
  ASSERT_EQ(rayline_cli("report " + path("sweep")).code, 0);
  ASSERT_TRUE(fs::exists(path("sweep/report.html")));
  r = rayline_cli(sweep);
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_FALSE(fs::exists(path("sweep/report.html")));
  expect_only({"run", "cmp", "sweep"});
}

TEST_F(OutputFolders, CompareAndSweepsCheckEveryRunsFolderBeforeTheFirstRun) {
  write("cmp/budge/mine.txt", "mine");
  auto r = rayline_cli("compare --platform paper-A --duration 1s --schedulers gmb,budge --out " + path("cmp"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("budge: --out: folder holds 'mine.txt'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("cmp/gmb"))) << "refused before GMB ran";
  EXPECT_EQ(read("cmp/budge/mine.txt"), "mine");
  // compare's results replace its whole folder, which therefore may hold nothing else.
  write("mine/thesis.tex", "precious");
  r = rayline_cli("compare --platform paper-A --duration 1s --schedulers gmb --out " + path("mine"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("mine: --out: folder holds 'thesis.tex'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("mine/compare.csv")));
  EXPECT_EQ(read("mine/thesis.tex"), "precious");
  // A client sweep writes OUT/clients-N: each is checked before the first point runs.
  write("sweep/clients-2/mine.txt", "mine");
  r = rayline_cli("simulate --workload museum --platform paper-A --duration 1s --no-progress --clients 1,2 --out " +
                  path("sweep"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("clients-2: --out: folder holds 'mine.txt'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("sweep/clients-1")));
  expect_only({"cmp", "mine", "sweep"});
}

// `compare --out .` wrote compare.csv and compare.json over the user's own files, and a
// scheduler's folder over theirs: compare's OUT is replaced as a whole, like simulate's, so
// it may hold only what compare writes (its tables, and scheduler folders of run files).
TEST_F(OutputFolders, CompareNeverOverwritesTheUsersFiles) {
  const std::string cmp = "compare --platform paper-A --duration 1s --schedulers gmb --out ";
  write("a/compare.csv", "my table");
  write("a/notes.txt", "mine");
  const fs::path before = fs::current_path();
  fs::current_path(path("a"));
  auto r = rayline_cli(cmp + ".");
  fs::current_path(before);
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find(".: --out: is the current folder or holds it"), std::string::npos) << r.err;
  r = rayline_cli(cmp + path("a"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--out: folder holds 'notes.txt'"), std::string::npos) << r.err;
  EXPECT_EQ(read("a/compare.csv"), "my table");
  EXPECT_FALSE(fs::exists(path("a/gmb")));
  // A folder of the user's that happens to bear a scheduler's name is theirs too.
  write("b/budge/photo.jpg", "mine");
  r = rayline_cli(cmp + path("b"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("budge: --out: folder holds 'photo.jpg'"), std::string::npos) << r.err;
  EXPECT_EQ(read("b/budge/photo.jpg"), "mine");
  // compare's own earlier results are replaced whole: a scheduler not run again goes.
  ASSERT_EQ(rayline_cli("compare --platform paper-A --duration 1s --schedulers gmb,budge --out " + path("c")).code, 0);
  r = rayline_cli(cmp + path("c"));
  EXPECT_EQ(r.code, 0) << r.all;
  EXPECT_TRUE(fs::exists(path("c/gmb/metrics.json")));
  EXPECT_TRUE(fs::exists(path("c/compare.json")));
  EXPECT_FALSE(fs::exists(path("c/budge"))) << "the earlier results are replaced, not merged";
  // The same for a client sweep's folder.
  write("s/notes.txt", "mine");
  r = rayline_cli("simulate --workload museum --platform paper-A --duration 1s --no-progress --clients 1,2 --out " +
                  path("s"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--out: folder holds 'notes.txt'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("s/clients-1")));
  expect_only({"a", "b", "c", "s"});
}

TEST_F(OutputFolders, PartitionReplacesOnlyAPartition) {
  ASSERT_EQ(rayline_cli("partition -q --blocks 4 --out " + path("p")).code, 0);
  ASSERT_EQ(rayline_cli("partition -q --blocks 2 --out " + path("p")).code, 0);
  EXPECT_FALSE(fs::exists(path("p/block_00003.rlb"))) << "the earlier partition is replaced";
  // A partition folder with something of the user's in it is not replaced, even when it
  // holds a blocks.json.
  write("p/readme.txt", "mine");
  auto r = rayline_cli("partition -q --blocks 4 --out " + path("p"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--out: folder holds 'readme.txt'"), std::string::npos) << r.err;
  EXPECT_EQ(read("p/readme.txt"), "mine");
  EXPECT_TRUE(fs::exists(path("p/block_00001.rlb")));
  r = rayline_cli("partition -q --out ''");
  EXPECT_EQ(r.code, 2) << r.all;
  expect_only({"p"});
}

TEST_F(OutputFolders, OutputFilesNamedAsFoldersAreRefusedBeforeTheWork) {
  fs::create_directory(path("d"));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"plan -q --trace " + path("d"), "--trace: is a folder"},
      {"plan -q --jobs-csv " + path("d"), "--jobs-csv: is a folder"},
      {"generate cornell -q --triangles 1000 --out " + path("d"), "--out: is a folder"},
      {"generate cornell -q --triangles 1000 --out " + path("g.ply") + " --scene-out " + path("d"), "--scene-out: is a folder"},
      {"render -q --spp 1 --resolution 8x8 --out " + path("r.exr") + " --record-replay " + path("d"),
       "--record-replay: is a folder"},
      {"render -q --spp 1 --resolution 8x8 --out " + path("r.exr") + " --record-profile " + path("d"),
       "--record-profile: is a folder"},
      {"calibrate --out " + path("d"), "--out: is a folder; give a file name such as out/this-machine.json"},
      {"calibrate --out ''", "--out: missing output path"},
  };
  for (const auto& [args, msg] : cases) {
    const auto r = rayline_cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.all;
    EXPECT_NE(r.err.find(msg), std::string::npos) << args << ": " << r.err;
  }
  EXPECT_TRUE(fs::is_empty(path("d")));
  expect_only({"d"});
}

// An output that names an input, or another output, is refused before the work: `render
// --record-profile SCENE.json` overwrote the scene with statistics (exit 0), and `plan
// --trace F --jobs-csv F` left only the CSV. The meshes a scene file names are inputs too:
// `render --scene S.json --record-profile MESH.ply` replaced the mesh with statistics.
TEST_F(OutputFolders, OutputsThatWouldOverwriteAnInputOrEachOtherAreRefused) {
  ASSERT_EQ(rayline_cli("generate cornell -q --triangles 1000 --out " + path("c.ply")).code, 0);
  const std::string scene = read("c.json"), mesh = read("c.ply");
  ASSERT_FALSE(scene.empty());
  ASSERT_FALSE(mesh.empty());
  fs::create_symlink(path("c.json"), path("link.json"));
  const std::string render = "render -q --spp 1 --resolution 8x8 --scene " + path("c.json") + " ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {render + "--out " + path("r.exr") + " --record-profile " + path("c.json"),
       "--record-profile: is the input of --scene"},
      {render + "--out " + path("r.exr") + " --record-replay " + path("link.json"),
       "--record-replay: is the input of --scene"},
      {render + "--out " + path("r.exr") + " --record-profile " + path("r.metrics.json"),
       "--record-profile: is also the file of --out (its metrics)"},
      {render + "--out " + path("r.exr") + " --record-profile " + path("x.log") + " --record-replay " + path("./x.log"),
       "--record-replay: is also the file of --record-profile"},
      {"plan -q --trace " + path("t.json") + " --jobs-csv " + path("t.json"), "--jobs-csv: is also the file of --trace"},
      {"plan -q --platform " + path("p.json") + " --trace " + path("p.json"), "--trace: is the input of --platform"},
      {"calibrate --scene " + path("c.json") + " --out " + path("link.json"), "--out: is the input of --scene"},
      {render + "--out " + path("r.exr") + " --record-profile " + path("c.ply"),
       "--record-profile: is the input of --scene (its mesh"},
      {render + "--out " + path("r.exr") + " --record-replay " + path("sub/../c.ply"),
       "--record-replay: is the input of --scene (its mesh"},
      {"calibrate --scene " + path("c.json") + " --out " + path("c.ply"), "--out: is the input of --scene (its mesh"},
  };
  fs::copy_file(std::string(RAYLINE_PLATFORMS) + "/paper-A.json", path("p.json"));
  for (const auto& [args, msg] : cases) {
    const auto r = rayline_cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.all;
    EXPECT_NE(r.err.find(msg), std::string::npos) << args << ": " << r.err;
  }
  EXPECT_EQ(read("c.json"), scene);
  EXPECT_EQ(read("c.ply"), mesh);
  EXPECT_FALSE(fs::exists(path("r.exr")));
  EXPECT_FALSE(fs::exists(path("t.json")));
  EXPECT_FALSE(fs::exists(path("x.log")));
}

// A glTF mesh reads its buffer files and names its textures: `render --scene m.gltf
// --record-replay m.bin` replaced the buffer with the log, and `--out tex.exr` the texture
// tex.png with the preview. Directly and through a JSON scene.
TEST_F(OutputFolders, OutputsNeverReplaceTheFilesAGltfMeshReads) {
  std::string bin;
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) bin.append(reinterpret_cast<const char*>(&f), sizeof f);
  write("tri.bin", bin);
  write("tex.png", "precious");
  write("tri.gltf",
        R"({"asset":{"version":"2.0"},"buffers":[{"uri":"tri.bin","byteLength":36}],)"
        R"("bufferViews":[{"buffer":0,"byteLength":36}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,)"
        R"("type":"VEC3","min":[0,0,0],"max":[1,1,0]}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
        R"("nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0,"images":[{"uri":"tex.png"}]})");
  write("s.json", R"({"meshes":[{"name":"tri","file":"tri.gltf"}],"cameras":{"main":{"position":[0.3,0.3,2],"look_at":[0.3,0.3,0]}}})");
  const std::string render = "render -q --spp 1 --resolution 8x8 --scene ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {render + path("tri.gltf") + " --out " + path("r.exr") + " --record-replay " + path("tri.bin"),
       "--record-replay: is the input of --scene (its file 'tri.bin')"},
      {render + path("tri.gltf") + " --out " + path("tex.exr"),
       "--out (its PNG preview): is the input of --scene (its file 'tex.png')"},
      {render + path("s.json") + " --out " + path("r.exr") + " --record-profile " + path("tri.bin"),
       "--record-profile: is the input of --scene (its mesh"},
      {"calibrate --scene " + path("s.json") + " --out " + path("tex.png"), "--out: is the input of --scene (its mesh"},
  };
  for (const auto& [args, msg] : cases) {
    const auto r = rayline_cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.all;
    EXPECT_NE(r.err.find(msg), std::string::npos) << args << ": " << r.err;
  }
  EXPECT_EQ(read("tri.bin"), bin);
  EXPECT_EQ(read("tex.png"), "precious");
  EXPECT_FALSE(fs::exists(path("r.exr")));
  // The scene itself renders (so the refusals above were not about a broken mesh).
  const auto r = rayline_cli(render + path("s.json") + " --out " + path("ok.exr"));
  EXPECT_EQ(r.code, 0) << r.all;
  EXPECT_TRUE(fs::exists(path("ok.exr")));
}

// A replay log recorded into OUT/ by one run, replayed by the next into the same OUT/: the
// second run replaced the folder and so deleted its own input.
TEST_F(OutputFolders, AnInputInsideTheFolderARunReplacesIsRefused) {
  const std::string run = "simulate --workload museum --platform paper-A --duration 1s --no-progress ";
  ASSERT_EQ(rayline_cli(run + "--record-replay --out " + path("rec")).code, 0);
  const std::string log = read("rec/replay.log");
  ASSERT_FALSE(log.empty());
  auto r = rayline_cli(run + "--fidelity replay --replay " + path("rec/replay.log") + " --out " + path("rec"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--replay: lies inside --out"), std::string::npos) << r.err;
  fs::create_directories(path("cmp/gmb"));
  fs::rename(path("rec/replay.log"), path("cmp/gmb/replay.log"));
  r = rayline_cli("compare --workload museum --platform paper-A --duration 1s --schedulers gmb --fidelity replay --replay " +
                  path("cmp/gmb/replay.log") + " --out " + path("cmp"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--replay: lies inside --out"), std::string::npos) << r.err;
  EXPECT_EQ(read("cmp/gmb/replay.log"), log);
  // Elsewhere, the same log replays.
  EXPECT_EQ(rayline_cli(run + "--fidelity replay --replay " + path("cmp/gmb/replay.log") + " --out " + path("rec")).code, 0);
}

// A compare's results appear whole or not at all. A stalled run completes (exit 1, its
// results say "stalled": true) and the set is published; a run that fails otherwise, here
// on a full disk (a file size limit), leaves the set incomplete and nothing is published.
// The children used to publish each run's folder on their own, and compare went on to write
// its tables beside whatever had been published.
TEST_F(OutputFolders, ACompareIsPublishedOnlyWhenEveryRunCompleted) {
  // 100 MB of RAM on the one node: nothing can run (tests/cli/test_cli_plan_simulate.cpp).
  auto p = nlohmann::json::parse(std::ifstream(std::string(RAYLINE_PLATFORMS) + "/paper-A.json"));
  p["node_types"]["A"]["memory"][1]["capacity"] = "100MB";
  write("small-ram.json", p.dump());
  auto r = rayline_cli("compare --platform " + path("small-ram.json") + " --duration 2s --schedulers gmb,budge --out " +
                       path("stalled"));
  EXPECT_EQ(r.code, 1) << r.all;
  EXPECT_NE(r.err.find("no chain of channels"), std::string::npos) << "the stall is explained: " << r.err;
  for (const char* s : {"gmb", "budge"}) {
    const auto m = nlohmann::json::parse(std::ifstream(path(std::string("stalled/") + s + "/metrics.json")));
    EXPECT_TRUE(m.at("stalled").get<bool>()) << s;
  }
  EXPECT_TRUE(fs::exists(path("stalled/compare.csv")));

  // On the paper cluster the runs' metrics and timelines exceed a 16 KiB file size limit.
  r = rayline_limited(RLIMIT_FSIZE, 16 << 10,
                      {"compare", "--duration", "10s", "--schedulers", "gmb,budge", "--out", path("full")});
  EXPECT_EQ(r.code, 1) << r.all;
  EXPECT_NE(r.err.find("cannot write"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("nothing is published under " + path("full")), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("full")));
  // The same for a client sweep.
  r = rayline_limited(RLIMIT_FSIZE, 16 << 10,
                      {"simulate", "--workload", "museum", "--duration", "10s", "--no-progress", "--clients", "1,2",
                       "--out", path("sweep")});
  EXPECT_EQ(r.code, 1) << r.all;
  EXPECT_NE(r.err.find("nothing is published under " + path("sweep")), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("sweep")));
  // One simulation: the message names the file under its final name, and why.
  r = rayline_limited(RLIMIT_FSIZE, 16 << 10, {"simulate", "--duration", "10s", "--no-progress", "--out", path("single")});
  EXPECT_EQ(r.code, 1) << r.all;
  EXPECT_NE(r.err.find("cannot write " + path("single") + "/"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("File too large"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(".partial."), std::string::npos) << "names the temporary folder: " << r.err;
  EXPECT_FALSE(fs::exists(path("single")));
  expect_only({"small-ram.json", "stalled"});
}

// `rayline render --record-twin` and `rayline simulate --like` (docs/validation.md): the
// recording does not change the image; the twin replays exactly the render's rays (every
// cell visit, every path) with the render's own batching code, and its block loads come
// within 25 % of the render's (loads depend on measured times, so the bound is loose
// here; the validation experiment holds the 10 % bounds). Bad inputs exit 2 naming the
// file and the field.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <nlohmann/json.hpp>

#include "cli/cli_run.hpp"
#include "cli/scratch_test.hpp"

namespace fs = std::filesystem;
using rayline::testing::rayline_cli;

namespace {
class CliTwin : public rayline::testing::ScratchTest {
 protected:
  nlohmann::json json_of(const std::string& name) const {
    std::ifstream in(path(name));
    return nlohmann::json::parse(in);
  }
  std::string slurp(const std::string& name) const {
    std::ifstream in(path(name), std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  // A render of the built-in scene in 16 blocks under a budget that makes it reload blocks.
  std::string render_args(const std::string& out) const {
    return "render -q --blocks-dir " + path("blocks") + " --resolution 96x96 --spp 2 --threads 2 --memory-budget 600KiB --out " +
           path(out);
  }
  void SetUp() override {
    ScratchTest::SetUp();
    const auto r = rayline_cli("partition -q --blocks 16 --out " + path("blocks"));
    ASSERT_EQ(r.code, 0) << r.all;
  }
};
}  // namespace

TEST_F(CliTwin, TwinReplaysTheRenderAndItsLoadsComeClose) {
  auto r = rayline_cli(render_args("plain.png"));
  ASSERT_EQ(r.code, 0) << r.all;
  r = rayline_cli(render_args("rec.png") + " --record-twin " + path("rec.twin.json"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_TRUE(fs::exists(path("rec.twin.rays")));
  EXPECT_EQ(slurp("plain.png"), slurp("rec.png")) << "recording the rays changed the image";
  const auto render = json_of("rec.metrics.json");

  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --out " + path("sim"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("twin of the recorded render"), std::string::npos) << r.out;
  const auto twin = json_of("sim/metrics.json").at("twin");
  EXPECT_TRUE(twin.at("frame_done").get<bool>());
  EXPECT_EQ(twin.at("block_visits"), render.at("rays").at("cell_visits"));
  EXPECT_EQ(twin.at("camera_rays"), render.at("rays").at("camera"));
  EXPECT_EQ(twin.at("paths_ended"), render.at("rays").at("camera")) << "every camera path ends";
  const double real_loads = render.at("io").at("loads").get<double>();
  const double sim_loads = twin.at("loads").get<double>();
  EXPECT_GT(real_loads, 16) << "the budget must force blocks to load again";
  EXPECT_LE(std::abs(sim_loads - real_loads), 0.25 * real_loads) << "simulated " << sim_loads << ", real " << real_loads;
  EXPECT_GT(twin.at("makespan_s").get<double>(), 0);

  // Markov fidelity: the log's statistics, sampled; the recorded run's own fitted timing.
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --fidelity markov --timing recorded --out " + path("sim-markov"));
  ASSERT_EQ(r.code, 0) << r.all;
  const auto markov = json_of("sim-markov/metrics.json").at("twin");
  EXPECT_TRUE(markov.at("frame_done").get<bool>());
  EXPECT_EQ(markov.at("paths_ended"), render.at("rays").at("camera"));
  const double visits = render.at("rays").at("cell_visits").get<double>();
  EXPECT_LE(std::abs(markov.at("block_visits").get<double>() - visits), 0.05 * visits);

  // The control loop's latency (platform "control_loop"): what the loop dispatches after a
  // finished job waits for it, so the same frame takes longer; the same rays are traced.
  auto plat = json_of("rec.twin.json").at("platform");
  plat.erase("control_loop");
  std::ofstream(path("no-loop.json")) << plat.dump();
  plat["control_loop"] = {{"per_job", "2ms"}, {"per_exec_second", 0.5}};
  std::ofstream(path("loop.json")) << plat.dump();
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --platform " + path("no-loop.json") + " --out " + path("sim-a"));
  ASSERT_EQ(r.code, 0) << r.all;
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --platform " + path("loop.json") + " --out " + path("sim-b"));
  ASSERT_EQ(r.code, 0) << r.all;
  const auto a = json_of("sim-a/metrics.json").at("twin"), b = json_of("sim-b/metrics.json").at("twin");
  EXPECT_EQ(a.at("block_visits"), b.at("block_visits"));
  EXPECT_GT(b.at("makespan_s").get<double>(), a.at("makespan_s").get<double>() + 0.002) << "the loop's latency is not felt";

  // What if the machine had more RAM: the same rays under a budget twice the size load no
  // more blocks; a budget below the largest block is refused, named.
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --memory-budget 1200KiB --out " + path("sim-more"));
  ASSERT_EQ(r.code, 0) << r.all;
  const auto more = json_of("sim-more/metrics.json").at("twin");
  EXPECT_TRUE(more.at("frame_done").get<bool>());
  EXPECT_EQ(more.at("block_visits"), render.at("rays").at("cell_visits"));
  EXPECT_LE(more.at("loads").get<double>(), sim_loads);
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --memory-budget 1KiB --out " + path("sim-less"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--memory-budget"), std::string::npos) << r.err;

  // The twin under another scheduler: the same rays, another plan.
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --scheduler budge --out " + path("sim-budge"));
  ASSERT_EQ(r.code, 0) << r.all;
  const auto m = json_of("sim-budge/metrics.json");
  EXPECT_EQ(m.at("scheduler"), "budge");
  EXPECT_EQ(m.at("twin").at("block_visits"), render.at("rays").at("cell_visits"));
}

TEST_F(CliTwin, BadTwinInputsExitTwoNamingFileAndField) {
  auto r = rayline_cli(render_args("rec.png") + " --record-twin " + path("rec.json"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("NAME.twin.json"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("rec.png"))) << "nothing rendered for a bad flag";

  r = rayline_cli(render_args("rec.png") + " --record-twin " + path("rec.twin.json"));
  ASSERT_EQ(r.code, 0) << r.all;
  // Both --like and --workload; --like on something else.
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --workload museum --out " + path("s1"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--like"), std::string::npos) << r.err;
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --duration 5s --out " + path("s1"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--duration"), std::string::npos) << r.err;
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --fidelity analytic --out " + path("s1"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--fidelity"), std::string::npos) << r.err;
  r = rayline_cli("simulate -q --workload " + path("rec.twin.json") + " --out " + path("s1"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("--like"), std::string::npos) << r.err;

  // A damaged twin file: a field out of range.
  auto t = json_of("rec.twin.json");
  t["batching"]["max_batch"] = 0;
  std::ofstream(path("bad.twin.json")) << t.dump();
  fs::copy_file(path("rec.twin.rays"), path("bad.twin.rays"));
  r = rayline_cli("simulate -q --like " + path("bad.twin.json") + " --out " + path("s2"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("bad.twin.json: batching.max_batch"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("s2")));
  // A batching switch that is not true or false.
  t = json_of("rec.twin.json");
  EXPECT_TRUE(t["batching"]["continue_in_cell"].get<bool>()) << "renders continue rays in their cell by default";
  t["batching"]["continue_in_cell"] = "yes";
  std::ofstream(path("bad.twin.json")) << t.dump();
  r = rayline_cli("simulate -q --like " + path("bad.twin.json") + " --out " + path("s2"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("bad.twin.json: batching.continue_in_cell"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("s2")));

  // A truncated ray log.
  fs::resize_file(path("rec.twin.rays"), fs::file_size(path("rec.twin.rays")) / 2);
  r = rayline_cli("simulate -q --like " + path("rec.twin.json") + " --out " + path("s3"));
  EXPECT_EQ(r.code, 2) << r.all;
  EXPECT_NE(r.err.find("rec.twin.rays"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("s3")));
}

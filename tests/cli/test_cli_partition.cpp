// `rayline partition`: outputs, timing line, exit codes for bad inputs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "cli/cli_run.hpp"
#include "cli/scratch_test.hpp"

namespace fs = std::filesystem;
using rayline::testing::rayline_cli;

namespace {
class CliPartition : public rayline::testing::ScratchTest {};
}  // namespace

TEST_F(CliPartition, DefaultSceneIntoBlocks) {
  const auto r = rayline_cli("partition --blocks 9 --out " + path("blocks"));
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_NE(r.out.find("MTriangles/s"), std::string::npos) << r.out;
  std::ifstream in(path("blocks/blocks.json"));
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("blocks").size(), 9u);
  EXPECT_TRUE(fs::exists(path("blocks/block_00008.rlb")));
}

TEST_F(CliPartition, GeneratedMeshAsScene) {
  ASSERT_EQ(rayline_cli("generate cornell --out " + path("c.ply") + " -q").code, 0);
  const auto r = rayline_cli("partition --scene " + path("c.ply") + " --blocks 5 --out " + path("b") + " -q");
  ASSERT_EQ(r.code, 0) << r.all;
  EXPECT_EQ(r.out.rfind("time ", 0), 0u) << r.out;
}

TEST_F(CliPartition, BadInputsExit2) {
  const std::string out = " --out " + path("b");
  for (const std::string& args :
       {std::string("partition --blocks 0") + out, std::string("partition --blocks abc") + out,
        std::string("partition --scene ") + path("missing.json") + out,
        std::string("partition --memory-limit 1XB") + out, std::string("partition --memory-limit 1MiB") + out,
        std::string("partition --blocks 1000000 --memory-limit 16MiB") + out,
        std::string("partition --out ") + std::string("/proc/rayline-cannot-create/blocks"), std::string("partition --bogus") + out}) {
    const auto r = rayline_cli(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.all;
    EXPECT_FALSE(r.err.empty()) << args;
  }
  std::ofstream(path("bad.json")) << "{ not json";
  EXPECT_EQ(rayline_cli("partition --scene " + path("bad.json") + out).code, 2);
  EXPECT_FALSE(fs::exists(path("b")));
}

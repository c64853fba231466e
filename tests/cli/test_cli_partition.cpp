// `rayline partition`: outputs, timing line, exit codes for bad inputs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <utility>
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
  EXPECT_NE(r.out.find(" triangles/s"), std::string::npos) << r.out;
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

// Degenerate extents: a mesh whose bounds are flat, thinner than ~1e-37 (a grid scale
// R / extent then overflows to infinity, and 0 × ∞ is NaN) or point-like is valid input.
// `partition` and `render` exit 0 on it; a mesh whose extent overflows the float range
// is refused with exit 2 naming the file.
TEST_F(CliPartition, DegenerateExtentsPartitionAndRender) {
  const std::pair<const char*, const char*> meshes[] = {
      {"thin.obj", "v 0 0 0\nv 1 0 0\nv 0 1e-40 1\nf 1 2 3\n"},
      {"flat.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 1\nf 1 2 3\nf 2 4 3\n"},
      {"point.obj", "v 0 0 0\nv 1e-40 0 0\nv 0 1e-40 1e-41\nf 1 2 3\n"},
  };
  for (const auto& [name, text] : meshes) {
    std::ofstream(path(name)) << text;
    const std::string blocks = path(std::string(name) + ".blocks");
    const auto p = rayline_cli("partition -q --blocks 8 --scene " + path(name) + " --out " + blocks);
    EXPECT_EQ(p.code, 0) << name << "\n" << p.all;
    for (const std::string& source : {std::string(" --blocks 8"), " --blocks-dir " + blocks}) {
      const auto r = rayline_cli("render -q --resolution 16x16 --spp 1 --scene " + path(name) + source + " --out " +
                                 path(std::string(name) + ".exr"));
      EXPECT_EQ(r.code, 0) << name << source << "\n" << r.all;
    }
  }
  std::ofstream(path("huge.obj")) << "v -3e38 0 0\nv 3e38 0 0\nv 0 3e38 1\nf 1 2 3\n";
  for (const std::string& cmd : {"partition -q --blocks 8 --out " + path("huge.blocks"),
                                 "render -q --resolution 16x16 --spp 1 --blocks 8 --out " + path("huge.exr")}) {
    const auto r = rayline_cli(cmd + " --scene " + path("huge.obj"));
    EXPECT_EQ(r.code, 2) << cmd << "\n" << r.all;
    EXPECT_NE(r.err.find("huge.obj"), std::string::npos) << r.err;
  }
}

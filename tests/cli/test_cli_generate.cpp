// `rayline generate` from the outside: a small scene is written completely (no temporary
// left), deterministic for a seed; bad input exits 2 naming the argument.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <cstdlib>
#include <unistd.h>

#include <string>
#include <vector>

#include "cli_run.hpp"

using rayline::testing::rayline_cli;
namespace fs = std::filesystem;

namespace {
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}
}  // namespace

TEST(CliGenerate, WritesADeterministicMesh) {
  const fs::path dir = fs::temp_directory_path() / ("rayline-cli-gen-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const auto a = rayline_cli("generate cornell --triangles 10K --seed 3 -q --out " + (dir / "a.ply").string());
  ASSERT_EQ(a.code, 0) << a.all;
  const auto b = rayline_cli("generate cornell --triangles 10K --seed 3 -q --out " + (dir / "b.ply").string());
  ASSERT_EQ(b.code, 0) << b.all;
  EXPECT_EQ(slurp(dir / "a.ply"), slurp(dir / "b.ply"));
  EXPECT_GT(fs::file_size(dir / "a.ply"), 100'000u);
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  ::unsetenv("RAYLINE_ASSETS");
  fs::remove_all(dir);
}

TEST(CliGenerate, BadInputExitsTwo) {
  auto r = rayline_cli("generate sponza --triangles 10K --out /tmp/x.ply");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.all.find("sponza"), std::string::npos) << r.all;
  r = rayline_cli("generate cornell --triangles 10Q --out /tmp/x.ply");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.all.find("--triangles"), std::string::npos) << r.all;
  r = rayline_cli("generate cornell --triangles 10K --out /proc/rayline-cannot-create/x.ply");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.all.find("--out"), std::string::npos) << r.all;
  // A seed is a whole number that fits in 64 bits: CLI11 alone would wrap -1 and clamp a
  // longer number without a word. The largest one is accepted.
  for (const std::string seed : {"-1", "18446744073709551616", "99999999999999999999", "0x10", "1.5"}) {
    r = rayline_cli("generate cornell --triangles 100 --seed " + seed + " --out /tmp/rayline-seed.ply");
    EXPECT_EQ(r.code, 2) << seed << ": " << r.all;
    EXPECT_NE(r.all.find("is not a seed"), std::string::npos) << r.all;
  }
  const fs::path ok = fs::temp_directory_path() / "rayline-seed-max.ply";
  r = rayline_cli("generate cornell --triangles 100 --seed 18446744073709551615 --scene-out - --out " + ok.string());
  EXPECT_EQ(r.code, 0) << r.all;
  fs::remove(ok);
  EXPECT_EQ(rayline_cli("generate --help").code, 0);
}

// Large counts run for minutes: --help says so, names the limits, and promises progress.
TEST(CliGenerate, HelpStatesTheCountLimitsAndProgress) {
  const auto r = rayline_cli("generate --help");
  ASSERT_EQ(r.code, 0) << r.all;
  for (const char* says : {"at most 4G", "progress line on stderr", "2^31 vertices"})
    EXPECT_NE(r.out.find(says), std::string::npos) << says << "\n" << r.out;
  EXPECT_EQ(rayline_cli("generate cornell --triangles 5G --out /tmp/rayline-too-many.ply").code, 2);
}

// The mesh is binary PLY whatever its name, and meshes are read back by their extension:
// `--out x.obj` wrote PLY bytes that no reader would take as OBJ. Nor may an output
// replace its companion scene or an asset file the generators read (`--out
// assets/dragon.ply` replaced the scan it had just loaded).
TEST(CliGenerate, OutputsAreAPlyMeshThatReplacesNoInput) {
  const fs::path dir = fs::temp_directory_path() / ("rayline-gen-out-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "assets");
  std::ofstream(dir / "assets" / "dragon.ply") << "not really a dragon";
  ::setenv("RAYLINE_ASSETS", (dir / "assets").string().c_str(), 1);  // (the binary inherits it)
  const std::string gen = "generate cornell --triangles 100 ";
  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {gen + "--out " + (dir / "x.obj").string(), "--out: the mesh is written as binary PLY"},
      {gen + "--out " + (dir / "x.ply").string() + " --scene-out " + (dir / "x.ply").string(),
       "--scene-out: is also the file of --out"},
      {gen + "--out " + (dir / "assets" / "dragon.ply").string(), "--out: is the input of the generators"},
      {gen + "--out " + (dir / "y.ply").string() + " --scene-out " + (dir / "assets/../assets/dragon.ply").string(),
       "--scene-out: is the input of the generators"},
  };
  for (const Case& c : cases) {
    const auto r = rayline_cli(c.args);
    EXPECT_EQ(r.code, 2) << c.args << ": " << r.all;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << ": " << r.err;
  }
  EXPECT_EQ(slurp(dir / "assets" / "dragon.ply"), "not really a dragon");
  EXPECT_FALSE(fs::exists(dir / "x.obj"));
  EXPECT_FALSE(fs::exists(dir / "x.ply"));
  EXPECT_FALSE(fs::exists(dir / "y.ply"));
  // An upper-case extension is still PLY.
  EXPECT_EQ(rayline_cli(gen + "-q --scene-out - --out " + (dir / "z.PLY").string()).code, 0);
  EXPECT_TRUE(fs::exists(dir / "z.PLY"));
  ::unsetenv("RAYLINE_ASSETS");
  fs::remove_all(dir);
}

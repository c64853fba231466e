// `rayline generate` from the outside: a small scene is written completely (no temporary
// left), deterministic for a seed; bad input exits 2 naming the argument.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <unistd.h>

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

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
  EXPECT_EQ(rayline_cli("generate --help").code, 0);
}

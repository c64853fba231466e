// JSON a user (or a fuzzer) can write that no loader may crash on: nested 100 000 levels
// deep, or holding a number no double holds. Every JSON input format — platform, job set,
// scene profile, scene, glTF — ends in exit 2 naming the file, never a signal or exit 1.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "cli_run.hpp"
#include "scratch_test.hpp"

namespace {

using rayline::testing::rayline_cli;
using rayline::testing::ScratchTest;

class HostileJson : public ScratchTest {
 protected:
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }
  // Each JSON format, read by the command that takes it.
  void expect_refused_everywhere(const std::string& stem, const std::string& text, const std::string& says) const {
    const std::string commands[][2] = {
        {".json", "platform check "},
        {".json", "plan --jobs "},
        {".profile.json", "simulate --duration 1s --out " + path("sim") + " --workload "},
        {".json", "render --resolution 8x8 --spp 1 --out " + path("r.exr") + " --scene "},
        {".gltf", "render --resolution 8x8 --spp 1 --out " + path("r.exr") + " --scene "},
    };
    for (const auto& [ext, command] : commands) {
      const std::string file = write(stem + ext, text);
      const rayline::testing::CliResult r = rayline_cli(command + file);
      EXPECT_EQ(r.code, 2) << command << file << "\n" << r.err;
      EXPECT_NE(r.err.find(file + ": "), std::string::npos) << command << "\n" << r.err;
      EXPECT_NE(r.err.find(says), std::string::npos) << command << "\n" << r.err;
    }
  }
};

TEST_F(HostileJson, DeepNestingIsBadInput) {
  expect_refused_everywhere("deep", "{\"nodes\": " + std::string(100000, '[') + std::string(100000, ']') + "}",
                            "nested more than 256 levels deep");
}

TEST_F(HostileJson, NumberOverflowIsBadInput) {
  expect_refused_everywhere("big", R"({"nodes": 1e400, "asset": {"version": "2.0"}})", "number overflow");
}

}  // namespace

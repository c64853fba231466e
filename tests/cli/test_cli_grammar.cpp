// One grammar for every subcommand (docs/cli.md): every error starts with "rayline:" and
// exits 2, CLI11's own parse errors included; durations and sizes without a unit are
// refused with the flag, the value and the units named; a short flag means one thing; the
// flag reference is printed by the binary and kept out of --help.
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_run.hpp"

using rayline::testing::rayline_cli;

namespace {

const std::string kPlatform = std::string(RAYLINE_PLATFORMS) + "/paper-A.json";

void expect_bad_input(const std::string& args, const std::string& prefix, const std::string& part) {
  const auto r = rayline_cli(args);
  EXPECT_EQ(r.code, 2) << args << "\n" << r.all;
  EXPECT_EQ(r.err.rfind(prefix, 0), 0u) << args << ": the message starts with '" << prefix << "'\n" << r.err;
  EXPECT_NE(r.err.find(part), std::string::npos) << args << ": names '" << part << "'\n" << r.err;
  EXPECT_TRUE(r.out.empty()) << args << "\n" << r.out;
}

}  // namespace

// Unknown flag, bad value, missing argument: CLI11's errors, in the form of every other one.
TEST(CliGrammar, ParseErrorsArePrefixedAndExitTwo) {
  const std::vector<std::string> subcommands = {"platform check " + kPlatform, "plan", "simulate", "compare", "generate",
                                                "partition", "render", "calibrate", "devices"};
  for (const std::string& sub : subcommands) {
    const std::string name = sub.substr(0, sub.find(" /"));
    expect_bad_input(sub + " --no-such-flag", "rayline: " + name + ": ", "--no-such-flag");
  }
  const std::vector<std::pair<std::string, std::string>> bad_values = {
      {"plan --synthetic-jobs many", "--synthetic-jobs"}, {"simulate --blocks x", "--blocks"},
      {"compare --seed x", "--seed"},                    {"generate --seed x", "--seed"},
      {"partition --blocks 0", "--blocks"},               {"render --spp abc", "--spp"},
      {"calibrate --threads 0", "--threads"},             {"devices --threads many", "--threads"},
      {"render --read-ahead maybe", "--read-ahead"},      {"simulate --transfer-order random", "--transfer-order"},
      {"simulate --exec-noise abc", "--exec-noise: 'abc' is not a FLOAT"}};
  for (const auto& [args, flag] : bad_values)
    expect_bad_input(args, "rayline: " + args.substr(0, args.find(' ')) + ": ", flag);
  const std::vector<std::pair<std::string, std::string>> missing = {
      {"plan --trace", "--trace"}, {"simulate --out", "--out"},  {"render -o", "--out"},
      {"partition -n", "--blocks"}, {"devices --gpu", "--gpu"}};
  for (const auto& [args, flag] : missing)
    expect_bad_input(args, "rayline: " + args.substr(0, args.find(' ')) + ": ", flag + ": 1 required");
  expect_bad_input("platform check", "rayline: platform check: ", "file");
  expect_bad_input("rendr", "rayline: ", "did you mean 'render'?");
}

// A duration or size without its unit is refused before any work, naming the flag, the
// value and the units the flag takes.
TEST(CliGrammar, BareNumbersNameTheFlagTheValueAndTheUnits) {
  const std::string durations = "units: ns, us, ms, s, min, h";
  const std::string sizes = "units: B, kB, MB, GB, TB, KiB, MiB, GiB, TiB";
  const std::vector<std::vector<std::string>> cases = {
      {"plan --horizon 2", "--horizon: '2'", durations},
      {"plan -k 0.5", "--horizon: '0.5'", durations},
      {"plan --aging 3", "--aging: ", durations},
      {"simulate --duration 60", "--duration: '60'", durations},
      {"simulate --workload museum --warmup 5", "--warmup: '5'", durations},
      {"simulate --platform paper-A --fail B@10 --duration 2s", "--fail: B@10: TIME: '10'", durations},
      {"compare --horizon 2", "--horizon: '2'", durations},
      {"render --horizon 2", "--horizon: '2'", durations},
      {"render -k 2", "--horizon: '2'", durations},
      {"render --aging 3", "--aging: ", durations},
      {"render --memory-budget 64", "--memory-budget: '64'", sizes},
      {"render --gpu-memory-budget 4096", "--gpu-memory-budget: '4096'", sizes},
      {"devices --memory-budget 64", "--memory-budget: '64'", sizes},
      {"devices --gpu-memory-budget 1", "--gpu-memory-budget: '1'", sizes},
      {"partition --memory-limit 64", "--memory-limit: '64'", sizes},
      {"partition --memory-limit 64M", "--memory-limit: '64M'", sizes},
      {"platform check " + kPlatform + " --block-size 210", "--block-size: '210'", sizes},
  };
  for (const auto& c : cases) {
    expect_bad_input(c[0], "rayline: ", c[1]);
    expect_bad_input(c[0], "rayline: ", c[2]);
  }
}

// Each short flag has one meaning (docs/cli.md), read off the flag reference: -o is --out
// wherever it exists, and so on; no other short flags.
TEST(CliGrammar, ShortFlagsMeanOneThing) {
  const auto r = rayline_cli("--cli-reference");
  ASSERT_EQ(r.code, 0) << r.all;
  const std::map<std::string, std::string> meaning = {{"-o", "--out"},     {"-q", "--quiet"},  {"-k", "--horizon"},
                                                      {"-n", "--blocks"},  {"-j", "--threads"}};
  std::set<std::string> seen;
  std::istringstream lines(r.out);
  int rows = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("| `-", 0) != 0 || line.rfind("| `--", 0) == 0) continue;  // rows that start with a short flag
    ++rows;
    const std::string shortf = line.substr(3, line.find('`', 3) - 3);  // "| `-o`, `--out` | ..."
    const auto m = meaning.find(shortf);
    ASSERT_NE(m, meaning.end()) << "short flag " << shortf << " is not in the rule of docs/cli.md: " << line;
    EXPECT_EQ(line.rfind("| `" + shortf + "`, `" + m->second + "`", 0), 0u) << line;
    seen.insert(shortf);
  }
  EXPECT_GE(rows, 15);
  EXPECT_EQ(seen.size(), meaning.size());
}

// --help describes every flag: no row of the reference has an empty meaning, and every
// DURATION and SIZE lists its units.
TEST(CliGrammar, EveryFlagIsDescribedWithItsUnits) {
  const auto r = rayline_cli("--cli-reference");
  ASSERT_EQ(r.code, 0) << r.all;
  std::istringstream lines(r.out);
  int rows = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("| `", 0) != 0) continue;
    ++rows;
    EXPECT_EQ(line.find(" |  |", line.size() - 5), std::string::npos) << "no meaning: " << line;
    if (line.find("| `DURATION") != std::string::npos) {
      EXPECT_NE(line.find("| ns, us, ms, s, min, h (required)"), std::string::npos) << line;
    }
    if (line.find("| `SIZE` |") != std::string::npos) {
      EXPECT_NE(line.find("| B, kB, MB, GB, TB, KiB, MiB, GiB, TiB (required)"), std::string::npos) << line;
    }
  }
  EXPECT_GE(rows, 100);
}

TEST(CliGrammar, ReferenceIsPrintedButNotListedInHelp) {
  const auto help = rayline_cli("--help");
  EXPECT_EQ(help.code, 0);
  EXPECT_EQ(help.out.find("cli-reference"), std::string::npos) << help.out;
  const auto r = rayline_cli("--cli-reference");
  EXPECT_EQ(r.code, 0) << r.all;
  for (const std::string part : {"## `rayline render`", "## `rayline platform check`",
                                 "| `-k`, `--horizon` | `DURATION` | ns, us, ms, s, min, h (required) | `2s` |",
                                 "| `--memory-limit` | `SIZE` |", "| `--triangles` | `COUNT` |"})
    EXPECT_NE(r.out.find(part), std::string::npos) << part;
}

// The top level of `rayline` (apps/main.cpp): a mistyped subcommand is named, with the
// closest existing one, and a missing one gets the list, exit code 2; known subcommands and
// their arguments pass through.
#include <gtest/gtest.h>

#include <string>

#include "cli_run.hpp"

namespace {

rayline::testing::CliResult rayline(const std::string& args) { return rayline::testing::rayline_cli(args); }

TEST(CliSubcommands, UnknownWordIsNamedWithTheClosestSubcommand) {
  const auto r = rayline("plna --platform paper-A");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("unknown subcommand 'plna'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("did you mean 'plan'?"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("platform, plan"), std::string::npos) << r.err;  // the list, in registration order
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(CliSubcommands, FarFromEveryNameGetsNoSuggestion) {
  const auto r = rayline("frobnicate");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("unknown subcommand 'frobnicate'"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("did you mean"), std::string::npos) << r.err;
}

TEST(CliSubcommands, NestedUnknownWordNamesItsParent) {
  const auto r = rayline("platform chekc platforms/paper-A.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("rayline: platform: unknown subcommand 'chekc', did you mean 'check'?"), std::string::npos)
      << r.err;
}

TEST(CliSubcommands, KnownSubcommandsAndPositionalsPassThrough) {
  // A positional after a subcommand without subcommands of its own is that subcommand's.
  const auto r = rayline(std::string("platform check ") + RAYLINE_PLATFORMS + "/paper-A.json");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("unknown subcommand"), std::string::npos) << r.err;
  EXPECT_EQ(rayline("--version").code, 0);
}

TEST(CliSubcommands, MissingSubcommandListsTheChoices) {
  const auto none = rayline("");
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.err.find("rayline: a subcommand is required, one of: platform, plan"), std::string::npos) << none.err;
  const auto nested = rayline("platform");
  EXPECT_EQ(nested.code, 2);
  EXPECT_NE(nested.err.find("rayline: platform: a subcommand is required, one of: check"), std::string::npos)
      << nested.err;
}

}  // namespace

// The flag reference of docs/cli.md, generated from the command line itself
// (`rayline --cli-reference`, scripts/update_cli_reference.sh), so that it cannot drift.
// Every option states the kind of value it takes as its CLI11 type name; the kinds with
// units are listed here, and the table prints the units each accepts.
#pragma once
#include <string>

namespace CLI {
class App;
}

namespace rayline::cli {

// Kinds of value (the type names in --help and in the table's "Value" column).
inline constexpr const char* kDuration = "DURATION";     // 2s, 500ms, 1.5min: a unit is required
inline constexpr const char* kSize = "SIZE";             // 64GiB, 512MiB, 4096B: a unit is required
inline constexpr const char* kCount = "COUNT";           // 250000, 10K, 100M, 1G
inline constexpr const char* kAging = "DURATION|auto|adaptive|off";
inline constexpr const char* kFault = "DEVICE@DURATION";  // --fail B3@10s
inline constexpr const char* kPath = "PATH";             // a file
inline constexpr const char* kFolder = "FOLDER";
inline constexpr const char* kResolution = "WIDTHxHEIGHT";
inline constexpr const char* kTiles = "TXxTY";

// The flag name that prints the reference; it is not listed in --help.
inline constexpr const char* kCliReferenceFlag = "--cli-reference";

// Markdown: per subcommand (nested ones too, in the order they were added) a heading, its
// description and a table of its options: flag names, value kind, units or allowed values,
// default, meaning. Options without a group (hidden) and --help are left out.
std::string cli_reference(const CLI::App& app);

}  // namespace rayline::cli

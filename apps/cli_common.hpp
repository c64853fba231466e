// Helpers shared by subcommands (no CLI11 here): error reporting and exit codes, the
// parsers of the command line's quantities and the formatters of the numbers it prints
// (the grammar in docs/cli.md).
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "sched/core/types.hpp"

namespace rayline::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;   // a run that failed for reasons other than input
inline constexpr int kExitBadInput = 2;  // bad platform/scene/profile/jobs file or flag

// A duration flag ("2s", "500ms", "1.5min"; units ns, us, ms, s, min, h) in seconds (>= 0).
// InputError naming the flag, the value and the accepted units otherwise: a bare number
// ("2"), an unknown unit, a negative or non-finite value, more than 1e9 s.
double duration_flag(const std::string& flag, const std::string& text);

// A size flag ("64GiB", "512MiB", "1.5GB", "4096B"; B with an optional k/M/G/T or
// Ki/Mi/Gi/Ti prefix) in whole bytes (>= 1). InputError naming the flag, the value and the
// accepted units otherwise: a bare number ("64"), bits ("8Gb"), zero, negative, over 1 EiB.
std::uint64_t size_flag(const std::string& flag, const std::string& text);

// The numbers every summary line prints, three significant digits and a unit:
//   format_duration(12.34) = "12.3 s", (0.0042) = "4.20 ms" (us, ns below)
//   format_size(1.5 * 2^30) = "1.50 GiB" (B, KiB, MiB, GiB, TiB: binary prefixes)
//   format_rate(4.273e6, "rays") = "4.27 M rays/s" (k, M, G, T: decimal prefixes)
//   format_bandwidth(1.5e8) = "150 MB/s" (decimal prefixes, as platform files write it)
std::string format_duration(double seconds);
std::string format_size(double bytes);
std::string format_rate(double per_second, const std::string& what);
std::string format_bandwidth(double bytes_per_second);

// Runs body(); turns InputError into "rayline: FILE: FIELD: msg" and exit 2, other
// std::exception into "rayline: error: msg" and exit 1.
int guarded(const std::function<int()>& body);

// Users expect `--out out/x` to work in a fresh checkout: create the missing parent
// folders of an output path; InputError(path, flag, ...) when they cannot be created.
void ensure_parent_dir(const std::string& path, const std::string& flag);
// The same for a folder itself (results folders): InputError(dir, flag, ...) naming it.
void ensure_dir(const std::string& dir, const std::string& flag);

// Before the work that an output file records: InputError(path, flag, ...) when `path` is
// empty, is a folder ("give a file name such as `example`"), or its folder cannot be created
// or written.
void check_output_file(const std::string& path, const std::string& flag, const std::string& example);

// A flag and the path it names.
struct NamedPath {
  std::string flag, path;
};
// Before the work: InputError when two outputs name the same file (the second would
// overwrite the first) or an output names an input (it would be overwritten while, or
// after, being read). Empty paths are skipped; existing files are compared by identity
// (hard and symbolic links included), others by their absolute, normalised path.
void check_distinct(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs);

// Before a run that replaces the results folder `folder`: InputError when an input lies
// inside it (a replay log recorded into OUT/ by the previous run, say), as the run would
// delete it with the folder it replaces.
void check_not_inside(const std::string& folder, const std::string& folder_flag, const std::vector<NamedPath>& inputs);

// Write `content` to `path` atomically (temporary name in the same folder, then rename).
// InputError when `path` is a folder; OutputWriteError (apps/run/output_set.hpp: a failed
// run, exit 1) when the file cannot be written, e.g. on a full disk.
void write_file_atomic(const std::string& path, const std::string& content);

}  // namespace rayline::cli

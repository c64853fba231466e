// Helpers shared by subcommands (no CLI11 here): error reporting and exit codes.
#pragma once
#include <functional>
#include <string>

namespace rayline::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;   // a run that failed for reasons other than input
inline constexpr int kExitBadInput = 2;  // bad platform/scene/profile/jobs file or flag

// Runs body(); turns InputError into "rayline: FILE: FIELD: msg" and exit 2, other
// std::exception into "rayline: error: msg" and exit 1.
int guarded(const std::function<int()>& body);

// Users expect `--out out/x` to work in a fresh checkout: create the missing parent
// folders of an output path; InputError(path, flag, ...) when they cannot be created.
void ensure_parent_dir(const std::string& path, const std::string& flag);

// Write `content` to `path` atomically (temporary name in the same folder, then rename).
void write_file_atomic(const std::string& path, const std::string& content);

}  // namespace rayline::cli

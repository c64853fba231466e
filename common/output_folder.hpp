// Replacing a command's results folder without losing anything of the user's (docs/architecture.md,
// "Bad input": nothing lost). `simulate`, `compare` and `partition` write their results into
// OUT.partial.<pid>@<host> and swap it in for OUT only once every file is complete. An existing OUT
// is replaced only when it is empty or holds nothing but files the command itself writes:
// so `--out .` or `--out ~` can never delete the folder's contents.
#pragma once
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace rayline {

// The names a command writes into its folder. A pattern may hold one '*' ("block_*.rlb").
using OwnFiles = std::vector<std::string_view>;

// The folder `path` as an absolute, normalised path (no trailing '/'), checked to be
// replaceable: absent (its parent is created later), or a folder that is empty or whose
// entries are all regular files matching `own`. Throws InputError(path, flag, ...) when the
// path is empty, is a file, is the current folder or holds it, or holds anything else (the
// first such entry is named).
std::string replaceable_folder(const std::string& path, const std::string& flag, const OwnFiles& own);

// The same for a folder of result folders (`compare`'s OUT/<scheduler>/, a client sweep's
// OUT/clients-N/): besides files matching `own`, entries that are folders (not links) matching
// `own_folders` are accepted once `check_folder(that folder's path)` returns; it throws
// InputError naming what the folder holds that the command does not write.
std::string replaceable_folder(const std::string& path, const std::string& flag, const OwnFiles& own,
                               const OwnFiles& own_folders, const std::function<void(const std::string&)>& check_folder);

// `path` made absolute, with links resolved as far as it exists, `.` and `..` folded and
// no trailing '/': how every check here compares paths.
std::string normal_path(const std::string& path);

// True when `path` is `folder` or lies inside it (both through normal_path).
bool folder_holds(const std::string& folder, const std::string& path);

// The sibling `target.partial.<pid>@<host>` a run writes into before publish_folder().
std::string partial_folder(const std::string& target);

// Swaps `partial` in for `target` (from replaceable_folder) in one step where the file
// system can (Linux renameat2), then removes the old target; else an existing target is
// first renamed aside and removed only once `partial` is in place, and put back if that
// fails. On failure InputError(target, flag, ...) is thrown, the old target is where it
// was, and `partial` is left for the caller to remove.
void publish_folder(const std::string& partial, const std::string& target, const std::string& flag);

}  // namespace rayline

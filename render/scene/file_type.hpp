// What a path given as an input file is, when it is not a regular file, in words for an
// InputError. Decided with stat(2) before anything opens the path: opening a FIFO for
// reading blocks until a writer appears, a folder opens and reads as empty, and a
// symbolic link loop fails with ELOOP, which std::filesystem reports as "does not exist".
#pragma once
#include <string>

namespace rayline::scene {

// "" when `path` (symbolic links followed) is a regular file; otherwise why it cannot be
// read as one, `what` naming the kind of file expected ("mesh file"): e.g. "is a FIFO
// (named pipe), not a mesh file", "is a symbolic link loop, not a mesh file",
// "mesh file does not exist".
std::string not_a_regular_file(const std::string& path, const std::string& what);

}  // namespace rayline::scene

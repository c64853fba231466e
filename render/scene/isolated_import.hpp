// Running an importer that is not trusted with malformed input in a child process.
//
// Assimp (Debian's 5.2.5) crashes, loops forever or leaks on some malformed files: its PLY
// loader dereferences a null pointer on a face element without a vertex index list, its
// SMD loader never returns on a NUL byte inside a line, and more such defects are known
// upstream (found by this repository's fuzz targets, docs/fuzzing.md). Rayline cannot fix
// them, so mesh_import.cpp runs every assimp import through import_in_child(): the child
// process imports and streams the triangle batches back through a pipe, and whatever
// becomes of it (a signal, an exit without a result, more CPU time than the file can need)
// is an InputError naming the file, the command's exit 2, never a crash of rayline.
//
// The child dies with its parent (PR_SET_PDEATHSIG), writes no core file, and is limited to
// assimp_cpu_seconds(path) of CPU time.
#pragma once
#include <cstdint>
#include <functional>
#include <string>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

// The CPU-time limit of the child importing `path`: 60 s plus 1 s per MiB of the file
// (assimp reads a 312 MB OBJ in about 30 s), or RAYLINE_ASSIMP_CPU_SECONDS when that is set
// to a positive whole number (scripts/fuzz.sh sets it below libFuzzer's timeout).
std::uint64_t assimp_cpu_seconds(const std::string& path);

// Runs `import` (which delivers triangles to its argument and returns the stats) in a
// child process; delivers the triangles to `fn` here, in the same batches and order.
// Rethrows an InputError of the child as an InputError(path, its field, its message), any
// other exception of the child as std::runtime_error(what), and throws
// InputError(path, "", "cannot import mesh: ...") when the child ends without a result.
// An exception thrown by `fn` stops the child and propagates.
ImportStats import_in_child(const std::string& path, const std::function<ImportStats(const TriangleBatchFn&)>& import,
                            const TriangleBatchFn& fn);

}  // namespace rayline::scene

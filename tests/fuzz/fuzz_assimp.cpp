// Formats without a native reader, which mesh_import.cpp hands to assimp (in a child
// process, validated before post-processing, walked by assimp_walk.cpp). Byte 0 of the
// input picks the extension (its value modulo the list below), the rest is the file;
// corpus files therefore start with one selector byte. Only the first step of
// fuzz_mesh.hpp runs (load_scene): each import forks, and the partitioner's two passes
// would import the same file twice more (the other mesh targets cover the partitioner).
#include <cstddef>
#include <cstdint>
#include <iterator>

#include "fuzz_mesh.hpp"

namespace {
const char* const kExtensions[] = {".raw", ".nff", ".ac", ".x",   ".smd", ".ase", ".dae",
                                   ".3ds", ".fbx", ".ms3d", ".lwo", ".b3d", ".md2", ".irrmesh"};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const char* ext = kExtensions[data[0] % std::size(kExtensions)];
  rayline::fuzz::run_mesh_file("assimp", std::string("input") + ext, data + 1, size - 1, /*partition=*/false);
  return 0;
}

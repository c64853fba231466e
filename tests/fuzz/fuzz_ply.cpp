// PLY files given as a scene (`rayline render --scene FILE.ply`, `partition --scene`):
// render/scene/mesh_import.cpp and its native reader (ply_reader.cpp; layouts it does not stream go to assimp), then the partitioner
// (fuzz_mesh.hpp).
#include "fuzz_mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  rayline::fuzz::run_mesh_file("ply", "input.ply", data, size);
  return 0;
}

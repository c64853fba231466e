// OBJ files given as a scene (`rayline render --scene FILE.obj`, `partition --scene`):
// render/scene/mesh_import.cpp and its native reader (obj_reader.cpp), then the partitioner
// (fuzz_mesh.hpp).
#include "fuzz_mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  rayline::fuzz::run_mesh_file("obj", "input.obj", data, size);
  return 0;
}

// STL files given as a scene (`rayline render --scene FILE.stl`, `partition --scene`):
// render/scene/mesh_import.cpp and its native reader (stl_reader.cpp), then the partitioner
// (fuzz_mesh.hpp).
#include "fuzz_mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  rayline::fuzz::run_mesh_file("stl", "input.stl", data, size);
  return 0;
}

// glTF 2.0 files given as a scene (`rayline render --scene FILE.gltf|.glb`): an input that
// starts with the GLB magic "glTF" is written as input.glb, any other as input.gltf; then
// render/scene/mesh_import.cpp, gltf_reader.cpp (assimp for what it does not read) and
// the partitioner (fuzz_mesh.hpp). External buffers resolve next to the input, in the
// target's scratch folder.
#include <cstring>

#include "fuzz_mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  rayline::fuzz::run_mesh_file("gltf", glb ? "input.glb" : "input.gltf", data, size);
  return 0;
}

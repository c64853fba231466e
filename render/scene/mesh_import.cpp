#include "render/scene/mesh_import.hpp"

#include <algorithm>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <filesystem>
#include <fstream>

#include "render/scene/assimp_walk.hpp"
#include "render/scene/file_type.hpp"
#include "render/scene/gltf_reader.hpp"
#include "render/scene/isolated_import.hpp"
#include "render/scene/obj_reader.hpp"
#include "render/scene/off_reader.hpp"
#include "render/scene/ply_reader.hpp"
#include "render/scene/stl_reader.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

std::string lower_ext(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

void check_readable(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // The type first: a FIFO would block the open below.
  if (const std::string problem = not_a_regular_file(path, "mesh file"); !problem.empty())
    throw InputError(path, "", problem);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open mesh file (permissions?)");
  if (fs::file_size(path, ec) == 0) throw InputError(path, "", "mesh file is empty");
}

// The in-memory fallback (see mesh_import.hpp for when it is used). Assimp's
// post-processing trusts the importer's output (Triangulate dereferences every face index
// and asserts on faces without one), so it runs only on a scene that passed assimp's
// aiProcess_ValidateDataStructure and check_ai_meshes; ReadFile with all three flags runs
// the same steps in the same order (validation, preprocessing, post-processing).
ImportStats stream_assimp_here(const std::string& path, const Affine& xf, const TriangleBatchFn& fn) {
  Assimp::Importer importer;
  const aiScene* sc = importer.ReadFile(path, aiProcess_ValidateDataStructure);
  if (!sc || !sc->mRootNode || (sc->mFlags & AI_SCENE_FLAGS_INCOMPLETE))
    throw InputError(path, "", std::string("cannot import mesh: ") + importer.GetErrorString());
  check_ai_meshes(*sc, path);
  // Keep points and lines (so they can be counted); triangulate polygons.
  sc = importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_SortByPType);
  if (!sc) throw InputError(path, "", std::string("cannot import mesh: ") + importer.GetErrorString());
  return stream_ai_scene(*sc, path, xf, fn);
}

// Assimp crashes and loops on some malformed files (isolated_import.hpp): it runs in a
// child process, whose failure is an InputError naming the file.
ImportStats stream_assimp(const std::string& path, const Affine& xf, const TriangleBatchFn& fn) {
  return import_in_child(path, [&](const TriangleBatchFn& out) { return stream_assimp_here(path, xf, out); }, fn);
}

}  // namespace

bool is_mesh_file(const std::string& path) {
  const std::string e = lower_ext(path);
  if (e == ".json" || e.empty()) return false;
  for (const char* native : {".obj", ".off", ".ply", ".stl", ".gltf", ".glb"})
    if (e == native) return true;
  Assimp::Importer importer;
  return importer.IsExtensionSupported(e);
}

ImportStats stream_mesh_file(const std::string& path, const Affine& xf, const TriangleBatchFn& fn,
                             ImportPath route) {
  check_readable(path);
  ImportStats st;
  const std::string e = lower_ext(path);
  // A PLY header is judged natively whichever path reads the file (ply_reader.hpp).
  const bool native_ply = e == ".ply" && read_ply_header(path).streamable;
  if (route == ImportPath::assimp) {
    st = stream_assimp(path, xf, fn);
  } else if (e == ".ply") {
    st = native_ply ? stream_ply(path, xf, fn) : stream_assimp(path, xf, fn);
  } else if (e == ".stl") {
    st = is_binary_stl(path) ? stream_stl(path, xf, fn) : stream_ascii_stl(path, xf, fn);
  } else if (e == ".obj") {
    st = stream_obj(path, xf, fn);
  } else if (e == ".off") {
    st = stream_off(path, xf, fn);
  } else if (e == ".gltf" || e == ".glb") {
    auto native = stream_gltf(path, xf, fn);
    st = native ? *native : stream_assimp(path, xf, fn);
  } else {
    st = stream_assimp(path, xf, fn);
  }
  if (st.triangles == 0)
    throw InputError(path, "", "no triangles found (" + std::to_string(st.skipped_primitives) +
                                   " non-triangle primitives skipped): empty or malformed mesh");
  return st;
}

ImportStats mesh_file_stats(const std::string& path, const Affine& xf) {
  return stream_mesh_file(path, xf, [](std::span<const Triangle>) {});
}

}  // namespace rayline::scene

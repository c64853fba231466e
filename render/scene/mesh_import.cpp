#include "render/scene/mesh_import.hpp"

#include <algorithm>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <filesystem>
#include <fstream>
#include <vector>

#include "render/scene/gltf_reader.hpp"
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

Affine to_affine(const aiMatrix4x4& m) {
  Affine a;
  const float* r[3] = {m[0], m[1], m[2]};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) a.m[i][j] = r[i][j];
  return a;
}

void check_readable(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "", "mesh file does not exist");
  if (fs::is_directory(path, ec)) throw InputError(path, "", "is a directory, not a mesh file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open mesh file (permissions?)");
  if (fs::file_size(path, ec) == 0) throw InputError(path, "", "mesh file is empty");
}

// The in-memory fallback (see mesh_import.hpp for when it is used).
ImportStats stream_assimp(const std::string& path, const Affine& xf, const TriangleBatchFn& fn) {
  Assimp::Importer importer;
  // Keep points and lines (so they can be counted); triangulate polygons.
  const aiScene* sc = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_SortByPType);
  if (!sc || !sc->mRootNode || (sc->mFlags & AI_SCENE_FLAGS_INCOMPLETE))
    throw InputError(path, "", std::string("cannot import mesh: ") + importer.GetErrorString());
  ImportStats st;
  std::vector<Triangle> buf;
  constexpr std::size_t kBatch = 1 << 16;
  buf.reserve(kBatch);
  struct Item {
    const aiNode* node;
    Affine world;
  };
  std::vector<Item> stack{{sc->mRootNode, xf * to_affine(sc->mRootNode->mTransformation)}};
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    for (unsigned k = 0; k < it.node->mNumMeshes; ++k) {
      const aiMesh* m = sc->mMeshes[it.node->mMeshes[k]];
      for (unsigned f = 0; f < m->mNumFaces; ++f) {
        const aiFace& face = m->mFaces[f];
        if (face.mNumIndices != 3) {
          ++st.skipped_primitives;
          continue;
        }
        Float3 v[3];
        for (int c = 0; c < 3; ++c) {
          const aiVector3D& p = m->mVertices[face.mIndices[c]];
          v[c] = it.world.point({p.x, p.y, p.z});
          st.bounds.extend(v[c]);
        }
        buf.push_back({v[0], v[1], v[2], m->mMaterialIndex});
        ++st.triangles;
        if (buf.size() == kBatch) fn(std::span<const Triangle>(buf)), buf.clear();
      }
    }
    for (unsigned c = it.node->mNumChildren; c-- > 0;) {
      const aiNode* ch = it.node->mChildren[c];
      stack.push_back({ch, it.world * to_affine(ch->mTransformation)});
    }
  }
  if (!buf.empty()) fn(std::span<const Triangle>(buf));
  return st;
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
  if (route == ImportPath::assimp) {
    st = stream_assimp(path, xf, fn);
  } else if (e == ".ply") {
    st = read_ply_header(path).streamable ? stream_ply(path, xf, fn) : stream_assimp(path, xf, fn);
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

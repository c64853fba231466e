#include "render/scene/assimp_walk.hpp"

#include <assimp/scene.h>

#include <unordered_set>
#include <vector>

#include "common/error.hpp"

namespace rayline::scene {
namespace {

Affine to_affine(const aiMatrix4x4& m) {
  Affine a;
  const float* r[3] = {m[0], m[1], m[2]};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) a.m[i][j] = r[i][j];
  return a;
}

std::string mesh_field(const aiScene& sc, unsigned index) {
  std::string f = "meshes[" + std::to_string(index) + "]";
  const aiMesh* m = sc.mMeshes[index];
  if (m && m->mName.length > 0) f += " '" + std::string(m->mName.C_Str()) + "'";
  return f;
}

std::string node_field(const aiNode* n, std::size_t visited) {
  std::string f = "nodes[" + std::to_string(visited) + "]";
  if (n->mName.length > 0) f += " '" + std::string(n->mName.C_Str()) + "'";
  return f;
}

std::string face_field(const std::string& mesh, unsigned face) { return mesh + ".faces[" + std::to_string(face) + "]"; }

std::string index_range(unsigned index, unsigned vertices) {
  return "vertex index " + std::to_string(index) + " out of range (" + std::to_string(vertices) + " vertices)";
}

}  // namespace

void check_ai_meshes(const aiScene& sc, const std::string& path) {
  if (sc.mNumMeshes > 0 && !sc.mMeshes) throw InputError(path, "meshes", "the imported scene lists no mesh array");
  for (unsigned i = 0; i < sc.mNumMeshes; ++i) {
    const aiMesh* m = sc.mMeshes[i];
    if (!m) throw InputError(path, "meshes[" + std::to_string(i) + "]", "null mesh");
    const std::string mesh = mesh_field(sc, i);
    if (m->mNumFaces > 0 && (!m->mFaces || !m->mVertices))
      throw InputError(path, mesh, "faces without face or vertex arrays");
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices == 0 || !face.mIndices) throw InputError(path, face_field(mesh, f), "a face without vertices");
      for (unsigned c = 0; c < face.mNumIndices; ++c)
        if (face.mIndices[c] >= m->mNumVertices)
          throw InputError(path, face_field(mesh, f), index_range(face.mIndices[c], m->mNumVertices));
    }
  }
}

ImportStats stream_ai_scene(const aiScene& sc, const std::string& path, const Affine& xf, const TriangleBatchFn& fn) {
  if (!sc.mRootNode) throw InputError(path, "nodes", "the imported scene has no root node");
  if (sc.mNumMeshes > 0 && !sc.mMeshes) throw InputError(path, "meshes", "the imported scene lists no mesh array");
  ImportStats st;
  std::vector<Triangle> buf;
  constexpr std::size_t kBatch = 1 << 16;
  buf.reserve(kBatch);
  struct Item {
    const aiNode* node;
    Affine world;
  };
  // Depth-first with an explicit stack, children in order. A node reached twice (a cycle
  // or a shared subtree) would repeat or never end the walk: the graph must be a tree.
  std::vector<Item> stack{{sc.mRootNode, xf * to_affine(sc.mRootNode->mTransformation)}};
  std::unordered_set<const aiNode*> seen{sc.mRootNode};
  std::size_t visited = 0;
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    const std::size_t index = visited++;
    auto node = [&] { return node_field(it.node, index); };
    if (it.node->mNumMeshes > 0 && !it.node->mMeshes) throw InputError(path, node(), "lists no mesh indices");
    for (unsigned k = 0; k < it.node->mNumMeshes; ++k) {
      const unsigned mi = it.node->mMeshes[k];
      if (mi >= sc.mNumMeshes)
        throw InputError(path, node() + ".meshes[" + std::to_string(k) + "]",
                         "mesh index " + std::to_string(mi) + " out of range (" + std::to_string(sc.mNumMeshes) +
                             " meshes)");
      const aiMesh* m = sc.mMeshes[mi];
      if (!m) throw InputError(path, "meshes[" + std::to_string(mi) + "]", "null mesh");
      const std::string mesh = mesh_field(sc, mi);
      if (m->mNumFaces > 0 && (!m->mFaces || !m->mVertices))
        throw InputError(path, mesh, "faces without face or vertex arrays");
      for (unsigned f = 0; f < m->mNumFaces; ++f) {
        const aiFace& face = m->mFaces[f];
        if (face.mNumIndices != 3) {
          ++st.skipped_primitives;
          continue;
        }
        if (!face.mIndices) throw InputError(path, face_field(mesh, f), "a face without vertices");
        Float3 v[3];
        for (int c = 0; c < 3; ++c) {
          const unsigned vi = face.mIndices[c];
          if (vi >= m->mNumVertices) throw InputError(path, face_field(mesh, f), index_range(vi, m->mNumVertices));
          const aiVector3D& p = m->mVertices[vi];
          v[c] = it.world.point({p.x, p.y, p.z});
          st.bounds.extend(v[c]);
        }
        buf.push_back({v[0], v[1], v[2], m->mMaterialIndex});
        ++st.triangles;
        if (buf.size() == kBatch) fn(std::span<const Triangle>(buf)), buf.clear();
      }
    }
    if (it.node->mNumChildren > 0 && !it.node->mChildren) throw InputError(path, node(), "lists no child nodes");
    for (unsigned c = it.node->mNumChildren; c-- > 0;) {
      const aiNode* ch = it.node->mChildren[c];
      if (!ch) throw InputError(path, node() + ".children[" + std::to_string(c) + "]", "null child node");
      if (!seen.insert(ch).second)
        throw InputError(path, node() + ".children[" + std::to_string(c) + "]",
                         "node reached twice: the node graph is not a tree");
      stack.push_back({ch, it.world * to_affine(ch->mTransformation)});
    }
  }
  if (!buf.empty()) fn(std::span<const Triangle>(buf));
  return st;
}

}  // namespace rayline::scene

// Adversarial mesh files on the assimp fallback path (mesh_import.hpp): what the native
// PLY reader can judge it refuses itself; what reaches assimp is validated before assimp's
// post-processing runs, and the imported scene is walked without trusting it
// (assimp_walk.hpp). Every case is an InputError naming the file, never a crash.
#include <gtest/gtest.h>

#include <assimp/scene.h>

#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "render/scene/assimp_walk.hpp"
#include "render/scene/mesh_import.hpp"
#include "scene_fixture.hpp"

namespace rayline::scene {
namespace {

using testing::TempDir;

class Adversarial : public TempDir {
 protected:
  // The InputError message of importing `file` along `route`, or "" if none was thrown.
  static std::string import_error(const std::string& file, ImportPath route = ImportPath::automatic) {
    try {
      stream_mesh_file(file, {}, [](std::span<const Triangle>) {}, route);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  static std::string ply(const std::string& header, const std::string& body) {
    return "ply\nformat ascii 1.0\n" + header + "end_header\n" + body;
  }
};

const std::string kVertices = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
const std::string kVertexData = "0 0 0\n1 0 0\n0 1 0\n";

void expect_names(const std::string& msg, const std::string& file, const std::string& field) {
  EXPECT_NE(msg.find(file), std::string::npos) << msg;
  EXPECT_NE(msg.find(field), std::string::npos) << msg;
}

// A float list-length type sent a face of 0 (or 1e9, or -1) indices to assimp's PLY loader
// and Triangulate (an assertion failure, an endless read, a bad_alloc); a float index type
// and repeated names were as ambiguous. The header is refused, whichever path reads on.
TEST_F(Adversarial, PlyHeadersTheNativeReaderRefuses) {
  const std::string face = "element face 1\n";
  const struct {
    const char* name;
    std::string text;
    const char* field;
  } cases[] = {
      {"float_count.ply", ply(kVertices + face + "property list float int vertex_indices\n", kVertexData + "0\n"),
       "header.property"},
      {"double_count.ply", ply(kVertices + face + "property list double int vertex_indices\n", kVertexData + "3 0 1 2\n"),
       "header.property"},
      {"float_index.ply", ply(kVertices + face + "property list uchar float vertex_indices\n", kVertexData + "3 0 1 2\n"),
       "header.property"},
      {"float_other_list.ply",
       ply(kVertices + face + "property list uchar int vertex_indices\nproperty list float float uv\n",
           kVertexData + "3 0 1 2 0\n"),
       "header.property"},
      {"dup_x.ply",
       ply("element vertex 3\nproperty float x\nproperty float x\nproperty float y\nproperty float z\n" + face +
               "property list uchar int vertex_indices\n",
           "0 0 0 0\n1 1 0 0\n0 0 1 0\n3 0 1 2\n"),
       "header.property"},
      {"dup_list.ply",
       ply(kVertices + face + "property list uchar int vertex_indices\nproperty list uchar int vertex_indices\n",
           kVertexData + "3 0 1 2 3 0 1 2\n"),
       "header.property"},
      {"two_lists.ply",
       ply(kVertices + face + "property list uchar int vertex_indices\nproperty list uchar int vertex_index\n",
           kVertexData + "3 0 1 2 3 0 1 2\n"),
       "header.property"},
      // A line that is no PLY header keyword: ignored, it sent the file to assimp, which
      // leaked on it (found by fuzzing).
      {"unknown_keyword.ply",
       ply("element vertex 3\nproperty float x\n'property float y\nproperty float z\n" + face +
               "property list uchar int vertex_indices\n",
           kVertexData + "3 0 1 2\n"),
       "unknown header keyword"},
      {"dup_element.ply",
       ply(kVertices + kVertices + face + "property list uchar int vertex_indices\n",
           kVertexData + kVertexData + "3 0 1 2\n"),
       "header.element"},
  };
  for (const auto& c : cases) {
    const std::string file = write(c.name, c.text);
    for (ImportPath route : {ImportPath::automatic, ImportPath::assimp}) {
      const std::string msg = import_error(file, route);
      expect_names(msg, c.name, c.field);
    }
  }
}

// A material_index no slot number holds (negative, 2^32 or more): converting it to the
// unsigned slot was undefined behaviour (found by fuzzing, binary int -2^31).
TEST_F(Adversarial, PlyMaterialIndexOutsideTheSlotRange) {
  const std::string header = "ply\nformat binary_little_endian 1.0\n" + kVertices +
                             "element face 1\nproperty list uchar int vertex_indices\nproperty int material_index\n"
                             "end_header\n";
  std::vector<unsigned char> bin;
  testing::put_text(bin, header);
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) testing::put<float>(bin, v);
  testing::put<std::uint8_t>(bin, 3);
  for (std::int32_t i : {0, 1, 2, std::numeric_limits<std::int32_t>::min()}) testing::put<std::int32_t>(bin, i);
  expect_names(import_error(write("negative.ply", bin)), "negative.ply", "face.material_index");
  const std::string face = "element face 1\nproperty list uchar int vertex_indices\nproperty float material_index\n";
  for (const char* m : {"-1", "1e30", "4294967296", "nan"})
    expect_names(import_error(write("ascii.ply", ply(kVertices + face, kVertexData + "3 0 1 2 " + m + "\n"))),
                 "ascii.ply", "line 14: face 0: bad or missing value for property 'material_index'");
  EXPECT_EQ(import_error(write("ok.ply", ply(kVertices + face, kVertexData + "3 0 1 2 4000000000\n"))), "");
}

// Files that do reach assimp: a face index past the vertices (PLY triangle strips, which
// only assimp reads) and a RAW file that revisits a group (assimp's RAW loader then leaves
// a null child node, which post-processing and the walk dereferenced).
TEST_F(Adversarial, AssimpFilesWithBrokenStructure) {
  const std::string strips = write(
      "strips.ply", ply(kVertices + "element tristrips 1\nproperty list int int vertex_indices\n", kVertexData + "3 0 1 9\n"));
  expect_names(import_error(strips), "strips.ply", "out of range");
  const std::string raw =
      write("groups.raw", "g1\n0 0 0 1 0 0 0 1 0\ng2\n0 0 0 1 0 0 0 1 0 1 1 1\ng1\n1 1 1 0 0 0 1 0 1 0 1 0\n");
  expect_names(import_error(raw), "groups.raw", "cannot import mesh");
  // Valid files on the same paths still import.
  EXPECT_EQ(import_error(write("ok.raw", "0 0 0 1 0 0 0 1 0\n1 1 1 0 0 0 1 1 1 0 0 1\n")), "");
  EXPECT_EQ(import_error(write("strip_ok.ply", ply(kVertices + "element tristrips 1\nproperty list int int vertex_indices\n",
                                                   kVertexData + "3 0 1 2\n"))),
            "");
}

// Found by fuzzing (tests/fuzz/): files on which assimp itself crashes (a PLY face element
// without a vertex index list: a null pointer dereferenced in its PLY loader) or never
// returns (an SMD "nodes" section cut short). Assimp runs in a child process
// (isolated_import.hpp), so each is an InputError naming the file and what happened.
TEST_F(Adversarial, AssimpCrashesAndEndlessLoopsAreInputErrors) {
  ::setenv("RAYLINE_ASSIMP_CPU_SECONDS", "1", 1);
  const std::string crash = write("crash.ply", ply("element vertex 1\nproperty float x\nproperty float y\n"
                                                   "element face 1\nproperty list uchar int e\n"
                                                   "property list uchar float texcoord\nproperty uchar x\n",
                                                   "0 5\n"));
  expect_names(import_error(crash), "crash.ply", "cannot import mesh: assimp crashed on this file (signal 11");
  const std::string loop = write("loop.smd", "nodes\nro");
  expect_names(import_error(loop), "loop.smd", "assimp did not finish within its CPU-time limit of 1 s");
  ::unsetenv("RAYLINE_ASSIMP_CPU_SECONDS");
  // The triangles of a file assimp reads come back from the child, and an error of the
  // consumer stops the child and reaches the caller.
  const std::string ok = write("ok.raw", "0 0 0 1 0 0 0 1 0\n1 1 1 0 0 0 1 1 1 0 0 1\n");
  std::vector<Triangle> got;
  const ImportStats st = stream_mesh_file(ok, {}, [&](std::span<const Triangle> t) { got.insert(got.end(), t.begin(), t.end()); });
  ASSERT_EQ(st.triangles, 2u);
  EXPECT_EQ(got.size(), 2u);
  EXPECT_EQ(st.bounds.lo.x, 0.0f);
  EXPECT_EQ(st.bounds.hi.x, 1.0f);
  EXPECT_THROW(stream_mesh_file(ok, {}, [](std::span<const Triangle>) { throw InputError("consumer", "", "stop"); }),
               InputError);
}

// ---- aiScene structures no importer is trusted not to build -------------------------

// Owns a hand-built aiScene and frees it without recursion (aiNode's destructor recurses).
struct BuiltScene {
  aiScene* sc = new aiScene();
  std::vector<aiNode*> nodes;
  aiNode* node(aiNode* parent = nullptr) {
    auto* n = new aiNode();
    nodes.push_back(n);
    n->mParent = parent;
    return n;
  }
  static void set_children(aiNode* n, std::vector<aiNode*> children) {
    n->mNumChildren = unsigned(children.size());
    n->mChildren = new aiNode*[children.size()];
    for (std::size_t i = 0; i < children.size(); ++i) n->mChildren[i] = children[i];
  }
  // One mesh: `vertices` vertices, the given faces.
  void mesh(unsigned vertices, const std::vector<std::vector<unsigned>>& faces, const char* name = "m") {
    auto* m = new aiMesh();
    m->mName = aiString(std::string(name));
    m->mNumVertices = vertices;
    m->mVertices = new aiVector3D[vertices];
    for (unsigned i = 0; i < vertices; ++i) m->mVertices[i] = aiVector3D(float(i), float(i % 2), 0);
    m->mNumFaces = unsigned(faces.size());
    m->mFaces = new aiFace[faces.size()];
    for (std::size_t f = 0; f < faces.size(); ++f) {
      m->mFaces[f].mNumIndices = unsigned(faces[f].size());
      m->mFaces[f].mIndices = faces[f].empty() ? nullptr : new unsigned[faces[f].size()];
      for (std::size_t c = 0; c < faces[f].size(); ++c) m->mFaces[f].mIndices[c] = faces[f][c];
    }
    auto** old = sc->mMeshes;
    sc->mMeshes = new aiMesh*[sc->mNumMeshes + 1];
    for (unsigned i = 0; i < sc->mNumMeshes; ++i) sc->mMeshes[i] = old[i];
    delete[] old;
    sc->mMeshes[sc->mNumMeshes++] = m;
  }
  static void use_mesh(aiNode* n, unsigned index) {
    n->mNumMeshes = 1;
    n->mMeshes = new unsigned[1]{index};
  }
  ~BuiltScene() {
    for (aiNode* n : nodes) {
      delete[] n->mChildren;
      n->mChildren = nullptr;
      n->mNumChildren = 0;
      delete n;
    }
    sc->mRootNode = nullptr;
    delete sc;
  }
};

std::string walk_error(const aiScene& sc) {
  try {
    check_ai_meshes(sc, "built.fbx");
    stream_ai_scene(sc, "built.fbx", {}, [](std::span<const Triangle>) {});
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(AssimpWalk, NullChildNodeIsAnError) {
  BuiltScene b;
  b.sc->mRootNode = b.node();
  b.mesh(3, {{0, 1, 2}});
  aiNode* child = b.node(b.sc->mRootNode);
  BuiltScene::use_mesh(child, 0);
  BuiltScene::set_children(b.sc->mRootNode, {child, nullptr});
  expect_names(walk_error(*b.sc), "built.fbx", "null child node");
}

TEST(AssimpWalk, FaceIndexPastTheVerticesNamesMeshAndFace) {
  BuiltScene b;
  b.sc->mRootNode = b.node();
  b.mesh(3, {{0, 1, 2}, {0, 1, 3}}, "Cube");
  BuiltScene::use_mesh(b.sc->mRootNode, 0);
  const std::string msg = walk_error(*b.sc);
  expect_names(msg, "built.fbx", "meshes[0] 'Cube'.faces[1]");
  EXPECT_NE(msg.find("vertex index 3 out of range (3 vertices)"), std::string::npos) << msg;
  // The walk checks on its own too (after post-processing, with no check_ai_meshes).
  try {
    stream_ai_scene(*b.sc, "built.fbx", {}, [](std::span<const Triangle>) {});
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("faces[1]"), std::string::npos) << e.what();
  }
}

TEST(AssimpWalk, FaceWithoutIndicesAndBadMeshIndexAreErrors) {
  BuiltScene b;
  b.sc->mRootNode = b.node();
  b.mesh(3, {{0, 1, 2}, {}});
  BuiltScene::use_mesh(b.sc->mRootNode, 0);
  expect_names(walk_error(*b.sc), "built.fbx", "faces[1]");
  BuiltScene c;
  c.sc->mRootNode = c.node();
  c.mesh(3, {{0, 1, 2}});
  BuiltScene::use_mesh(c.sc->mRootNode, 5);
  expect_names(walk_error(*c.sc), "built.fbx", "mesh index 5 out of range");
}

TEST(AssimpWalk, NodeReachedTwiceIsAnError) {
  BuiltScene b;
  b.sc->mRootNode = b.node();
  b.mesh(3, {{0, 1, 2}});
  aiNode* shared = b.node(b.sc->mRootNode);
  BuiltScene::use_mesh(shared, 0);
  BuiltScene::set_children(b.sc->mRootNode, {shared, shared});
  expect_names(walk_error(*b.sc), "built.fbx", "not a tree");
}

// A hierarchy deeper than a recursive walk's stack allows (each aiNode is about 1 KiB,
// so this builds about 110 MB): the innermost transform applies, and the walk ends.
TEST(AssimpWalk, DeepHierarchyWalksIteratively) {
  BuiltScene b;
  b.mesh(3, {{0, 1, 2}});
  constexpr int kDepth = 100000;
  aiNode* n = b.sc->mRootNode = b.node();
  for (int d = 0; d < kDepth; ++d) {
    aiNode* c = b.node(n);
    BuiltScene::set_children(n, {c});
    n = c;
  }
  BuiltScene::use_mesh(n, 0);
  n->mTransformation = aiMatrix4x4(aiVector3D(1, 1, 1), aiQuaternion(), aiVector3D(0, 0, 5));
  std::uint64_t triangles = 0;
  const ImportStats st = stream_ai_scene(*b.sc, "deep.fbx", {}, [&](std::span<const Triangle> t) { triangles += t.size(); });
  EXPECT_EQ(st.triangles, 1u);
  EXPECT_EQ(triangles, 1u);
  EXPECT_EQ(st.bounds.lo.z, 5.0f);
}

}  // namespace
}  // namespace rayline::scene

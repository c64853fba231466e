// Import of every supported format through mesh_import: triangle counts, skipped
// primitives and bounds on tiny fixtures written here; malformed and missing files give
// InputError naming them. Format details: test_mesh_text_formats.cpp, test_mesh_gltf.cpp;
// memory bounds and agreement with assimp: test_mesh_streaming.cpp.
#include <gtest/gtest.h>

#include <cstring>

#include "render/scene/mesh_import.hpp"
#include "render/scene/ply_reader.hpp"
#include "render/scene/scene.hpp"
#include "render/scene/stl_reader.hpp"
#include "scene_fixture.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

using testing::put;
using testing::put_text;

class Import : public testing::TempDir {};

void expect_bounds(const Bounds& b, Float3 lo, Float3 hi) {
  EXPECT_NEAR(b.lo.x, lo.x, 1e-5f); EXPECT_NEAR(b.lo.y, lo.y, 1e-5f); EXPECT_NEAR(b.lo.z, lo.z, 1e-5f);
  EXPECT_NEAR(b.hi.x, hi.x, 1e-5f); EXPECT_NEAR(b.hi.y, hi.y, 1e-5f); EXPECT_NEAR(b.hi.z, hi.z, 1e-5f);
}

// Unit square (a quad) at z = 0 plus one triangle at z = 1, as binary PLY: 3 triangles.
// Vertices carry an extra `confidence` property and doubles when `dbl`.
std::vector<unsigned char> binary_ply(bool big, bool dbl) {
  std::vector<unsigned char> b;
  put_text(b, std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\ncomment test\nelement vertex 5\n" +
                  (dbl ? "property double x\nproperty double y\nproperty double z\n"
                       : "property float x\nproperty float y\nproperty float z\n") +
                  "property float confidence\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n");
  const float v[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1}};
  for (auto& p : v) {
    for (float c : p) dbl ? put<double>(b, c, big) : put<float>(b, c, big);
    put<float>(b, 1.0f, big);
  }
  put<std::uint8_t>(b, 4, big);
  for (int i : {0, 1, 2, 3}) put<std::int32_t>(b, i, big);
  put<std::uint8_t>(b, 3, big);
  for (int i : {0, 1, 4}) put<std::int32_t>(b, i, big);
  return b;
}

TEST_F(Import, BinaryPlyLittleEndianNativeAndAssimpAgree) {
  const auto p = write("le.ply", binary_ply(false, false));
  EXPECT_TRUE(read_ply_header(p).streamable);
  for (auto route : {ImportPath::automatic, ImportPath::assimp}) {
    const ImportStats s = stream_mesh_file(p, {}, [](std::span<const Triangle>) {}, route);
    EXPECT_EQ(s.triangles, 3u);
    expect_bounds(s.bounds, {0, 0, 0}, {1, 1, 1});
  }
}

TEST_F(Import, BinaryPlyBigEndianAndDoubles) {
  for (bool dbl : {false, true}) {
    const auto p = write(dbl ? "be64.ply" : "be.ply", binary_ply(true, dbl));
    for (auto route : {ImportPath::automatic, ImportPath::assimp}) {
      const ImportStats s = stream_mesh_file(p, {}, [](std::span<const Triangle>) {}, route);
      EXPECT_EQ(s.triangles, 3u) << p;
      expect_bounds(s.bounds, {0, 0, 0}, {1, 1, 1});
    }
  }
}

TEST_F(Import, AsciiPly) {
  const auto p = write("a.ply",
                       "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                       "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                       "0 0 0\n2 0 0\n2 3 0\n0 3 0\n4 0 1 2 3\n");
  EXPECT_TRUE(read_ply_header(p).streamable);  // native since the text readers stream too
  EXPECT_FALSE(read_ply_header(p).binary);
  for (auto route : {ImportPath::automatic, ImportPath::assimp}) {
    const ImportStats s = stream_mesh_file(p, {}, [](std::span<const Triangle>) {}, route);
    EXPECT_EQ(s.triangles, 2u);
    expect_bounds(s.bounds, {0, 0, 0}, {2, 3, 0});
  }
}

TEST_F(Import, ObjTriangulatesPolygonsAndSkipsLines) {
  const auto p = write("m.obj",
                       "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 -2\n"
                       "f 1 2 3 4\nf 1 2 5\nl 1 3\n");
  const ImportStats s = mesh_file_stats(p);
  EXPECT_EQ(s.triangles, 3u);
  EXPECT_EQ(s.skipped_primitives, 1u);
  expect_bounds(s.bounds, {0, 0, -2}, {1, 1, 0});
}

TEST_F(Import, StlAsciiAndBinary) {
  const auto a = write("a.stl",
                       "solid t\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n"
                       "  endloop\n endfacet\n facet normal 0 0 1\n  outer loop\n   vertex 1 0 0\n   vertex 1 1 0\n"
                       "   vertex 0 1 5\n  endloop\n endfacet\nendsolid t\n");
  ImportStats s = mesh_file_stats(a);
  EXPECT_EQ(s.triangles, 2u);
  expect_bounds(s.bounds, {0, 0, 0}, {1, 1, 5});

  std::vector<unsigned char> b(80, ' ');
  put<std::uint32_t>(b, 3);
  for (int t = 0; t < 3; ++t) {
    for (float c : {0.0f, 0.0f, 1.0f}) put<float>(b, c);
    const float v[3][3] = {{float(t), 0, 0}, {float(t) + 1, 0, 0}, {float(t), 2, -1}};
    for (auto& p : v)
      for (float c : p) put<float>(b, c);
    put<std::uint16_t>(b, 0);
  }
  s = mesh_file_stats(write("b.stl", b));
  EXPECT_EQ(s.triangles, 3u);
  expect_bounds(s.bounds, {0, 0, -1}, {3, 2, 0});
}

// Binary STL goes through the native streaming reader: counts and bounds in small
// batches, the same as assimp; truncation and count mismatches name file and field.
TEST_F(Import, BinaryStlNativeReader) {
  std::vector<unsigned char> b(80, 's');  // header even starts like "solid"
  std::memcpy(b.data(), "solid but binary", 16);
  put<std::uint32_t>(b, 5);
  for (int t = 0; t < 5; ++t) {
    for (float c : {0.0f, 0.0f, 1.0f}) put<float>(b, c);
    const float v[3][3] = {{float(t), 0, 0}, {float(t) + 1, 0, 3}, {float(t), 2, -1}};
    for (auto& p : v)
      for (float c : p) put<float>(b, c);
    put<std::uint16_t>(b, 7);
  }
  const auto f = write("n.stl", b);
  EXPECT_TRUE(is_binary_stl(f));
  std::size_t batches = 0, tris = 0;
  ImportStats s = stream_stl(f, {}, [&](std::span<const Triangle> t) { ++batches, tris += t.size(); }, 2);
  EXPECT_EQ(s.triangles, 5u);
  EXPECT_EQ(tris, 5u);
  EXPECT_EQ(batches, 3u);
  expect_bounds(s.bounds, {0, 0, -1}, {5, 2, 3});
  const ImportStats viaimport = mesh_file_stats(f);
  EXPECT_EQ(viaimport.triangles, 5u);
  expect_bounds(viaimport.bounds, {0, 0, -1}, {5, 2, 3});
  const ImportStats viaassimp = stream_mesh_file(f, {}, [](std::span<const Triangle>) {}, ImportPath::assimp);
  EXPECT_EQ(viaassimp.triangles, 5u);

  auto expect_error = [](const std::string& path, const std::string& field) {
    try {
      stream_stl(path, {}, [](std::span<const Triangle>) {});
      ADD_FAILURE() << "no error for " << path;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ(e.field(), field) << e.what();
    }
  };
  std::vector<unsigned char> cut(b.begin(), b.end() - 20);
  const auto truncated = write("cut.stl", cut);
  expect_error(truncated, "triangle_count");
  EXPECT_THROW(mesh_file_stats(truncated), InputError);
  std::vector<unsigned char> longer = b;
  longer.resize(b.size() + 50);
  expect_error(write("long.stl", longer), "triangle_count");
  expect_error(write("short.stl", std::vector<unsigned char>(b.begin(), b.begin() + 40)), "header");
  // ASCII STL is not taken for binary.
  EXPECT_FALSE(is_binary_stl(write("a.stl", "solid t\nendsolid t\n")));
}

TEST_F(Import, Off) {
  const auto p = write("m.off", "OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 4\n4 0 1 2 3\n3 0 1 4\n");
  const ImportStats s = mesh_file_stats(p);
  EXPECT_EQ(s.triangles, 3u);
  expect_bounds(s.bounds, {0, 0, 0}, {1, 1, 4});
}

// A glTF scene: root node translated by (10, 0, 0) whose child (scaled by 2) holds a unit
// quad made of two indexed triangles. Flattening must give x in [10, 12], y in [0, 2].
std::vector<unsigned char> gltf_buffer() {
  std::vector<unsigned char> b;
  const float v[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  for (auto& p : v)
    for (float c : p) put<float>(b, c);
  for (std::uint16_t i : {0, 1, 2, 0, 2, 3}) put<std::uint16_t>(b, i);
  return b;  // 48 + 12 = 60 bytes
}
std::string gltf_json(const std::string& buffer_uri) {
  return std::string(R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],)") +
         R"("nodes":[{"translation":[10,0,0],"children":[1]},{"scale":[2,2,2],"mesh":0}],)" +
         R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],)" +
         R"("accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},)" +
         R"({"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}],)" +
         R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":12}],)" +
         R"("buffers":[{)" + buffer_uri + R"("byteLength":60}]})";
}

TEST_F(Import, GltfEmbeddedFlattensNodeTransforms) {
  const auto p = write("m.gltf", gltf_json(R"("uri":"data:application/octet-stream;base64,)" +
                                           testing::base64(gltf_buffer()) + "\","));
  const ImportStats s = mesh_file_stats(p);
  EXPECT_EQ(s.triangles, 2u);
  expect_bounds(s.bounds, {10, 0, 0}, {12, 2, 0});
}

TEST_F(Import, Glb) {
  std::string json = gltf_json("");
  while (json.size() % 4) json += ' ';
  const auto bin = gltf_buffer();
  std::vector<unsigned char> b;
  put<std::uint32_t>(b, 0x46546C67);  // "glTF"
  put<std::uint32_t>(b, 2);
  put<std::uint32_t>(b, std::uint32_t(12 + 8 + json.size() + 8 + bin.size()));
  put<std::uint32_t>(b, std::uint32_t(json.size()));
  put<std::uint32_t>(b, 0x4E4F534A);  // "JSON"
  put_text(b, json);
  put<std::uint32_t>(b, std::uint32_t(bin.size()));
  put<std::uint32_t>(b, 0x004E4942);  // "BIN\0"
  b.insert(b.end(), bin.begin(), bin.end());
  const ImportStats s = mesh_file_stats(write("m.glb", b));
  EXPECT_EQ(s.triangles, 2u);
  expect_bounds(s.bounds, {10, 0, 0}, {12, 2, 0});
}

TEST_F(Import, TransformIsApplied) {
  const auto p = write("le.ply", binary_ply(false, false));
  const ImportStats s = mesh_file_stats(p, Affine::translate({5, 0, 0}) * Affine::scale({2, 2, 2}));
  expect_bounds(s.bounds, {5, 0, 0}, {7, 2, 2});
}

TEST_F(Import, MissingFileNamesIt) {
  try {
    mesh_file_stats(path("nope.obj"));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path("nope.obj"));
  }
}

TEST_F(Import, MalformedFilesAreInputErrors) {
  EXPECT_THROW(mesh_file_stats(write("junk.obj", "this is not\x01\x02 a mesh {{{\n")), InputError);
  EXPECT_THROW(mesh_file_stats(write("empty.stl", "")), InputError);
  EXPECT_THROW(mesh_file_stats(write("junk.glb", "glTF garbage")), InputError);
  // Truncated binary PLY: header promises 2 faces, data stops inside the vertex block.
  auto b = binary_ply(false, false);
  b.resize(b.size() - 40);
  EXPECT_THROW(mesh_file_stats(write("trunc.ply", b)), InputError);
  // Out-of-range index.
  b = binary_ply(false, false);
  b[b.size() - 1] = 99;
  EXPECT_THROW(mesh_file_stats(write("badindex.ply", b)), InputError);
}

}  // namespace
}  // namespace rayline::scene

namespace rayline::scene {
namespace {

// Real assets (scripts/fetch_assets.sh); skipped when they have not been fetched.
TEST(Assets, RealMeshesAndTheirScenes) {
  const std::string a = RAYLINE_ASSETS_DIR;
  if (!std::filesystem::exists(a + "/bunny.obj") || !std::filesystem::exists(a + "/dragon.ply"))
    GTEST_SKIP() << "assets not fetched (scripts/fetch_assets.sh)";
  EXPECT_EQ(mesh_file_stats(a + "/bunny.obj").triangles, 69666u);
  EXPECT_EQ(mesh_file_stats(a + "/dragon.ply").triangles, 871414u);
  for (const char* s : {"bunny.json", "dragon.json"})
    EXPECT_NO_THROW(load_scene(std::string(RAYLINE_SCENES_DIR) + "/assets/" + s)) << s;
}

}  // namespace
}  // namespace rayline::scene

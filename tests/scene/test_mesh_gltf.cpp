// Native glTF 2.0 reader: .gltf with an external .bin, .glb, base64 data URIs; node
// hierarchies (matrix and T·R·S) flattened into the vertices; every primitive mode;
// quantized positions; skipped primitive counts; errors naming the file and the JSON path.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "render/scene/gltf_reader.hpp"
#include "render/scene/mesh_import.hpp"
#include "scene_fixture.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

using json = nlohmann::json;
using testing::put;

void expect_bounds(const Bounds& b, Float3 lo, Float3 hi) {
  EXPECT_NEAR(b.lo.x, lo.x, 1e-5f); EXPECT_NEAR(b.lo.y, lo.y, 1e-5f); EXPECT_NEAR(b.lo.z, lo.z, 1e-5f);
  EXPECT_NEAR(b.hi.x, hi.x, 1e-5f); EXPECT_NEAR(b.hi.y, hi.y, 1e-5f); EXPECT_NEAR(b.hi.z, hi.z, 1e-5f);
}

template <class F>
void expect_error(F&& f, const std::string& file, const std::string& field, const std::string& text = "") {
  try {
    f();
    ADD_FAILURE() << "no InputError (expected " << field << ")";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file) << e.what();
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what() << "\n  expected: " << text;
  }
}

// Builds a glTF document and its single binary buffer.
struct Builder {
  std::vector<unsigned char> bin;
  json doc = {{"asset", {{"version", "2.0"}}}, {"bufferViews", json::array()}, {"accessors", json::array()},
              {"meshes", json::array()}};

  int view(const std::vector<unsigned char>& bytes, int stride = 0) {
    while (bin.size() % 4) bin.push_back(0);
    json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}};
    if (stride) v["byteStride"] = stride;
    bin.insert(bin.end(), bytes.begin(), bytes.end());
    doc["bufferViews"].push_back(v);
    return int(doc["bufferViews"].size()) - 1;
  }
  int accessor(int view, int component, std::size_t count, const std::string& type, std::size_t offset = 0,
               bool normalized = false) {
    json a = {{"bufferView", view}, {"componentType", component}, {"count", count}, {"type", type}};
    if (offset) a["byteOffset"] = offset;
    if (normalized) a["normalized"] = true;
    doc["accessors"].push_back(a);
    return int(doc["accessors"].size()) - 1;
  }
  int positions(const std::vector<Float3>& p) {
    std::vector<unsigned char> b;
    for (auto& v : p) put<float>(b, v.x), put<float>(b, v.y), put<float>(b, v.z);
    return accessor(view(b), 5126, p.size(), "VEC3");
  }
  int indices(const std::vector<std::uint32_t>& idx, int component = 5123) {
    std::vector<unsigned char> b;
    for (auto i : idx) {
      if (component == 5121) put<std::uint8_t>(b, std::uint8_t(i));
      else if (component == 5123) put<std::uint16_t>(b, std::uint16_t(i));
      else put<std::uint32_t>(b, i);
    }
    return accessor(view(b), component, idx.size(), "SCALAR");
  }
  static json primitive(int pos, int idx = -1, int mode = -1, int material = -1) {
    json p = {{"attributes", json::object()}};
    if (pos >= 0) p["attributes"]["POSITION"] = pos;
    if (idx >= 0) p["indices"] = idx;
    if (mode >= 0) p["mode"] = mode;
    if (material >= 0) p["material"] = material;
    return p;
  }
  int mesh(std::vector<json> prims) {
    doc["meshes"].push_back({{"primitives", prims}});
    return int(doc["meshes"].size()) - 1;
  }
  // The buffer as an external file `bin_name`, or base64 inside the JSON (bin_name "").
  std::string gltf(const std::string& bin_name) {
    json d = doc;
    d["buffers"] = json::array({{{"byteLength", bin.size()}}});
    d["buffers"][0]["uri"] = bin_name.empty() ? "data:application/octet-stream;base64," + testing::base64(bin) : bin_name;
    return d.dump();
  }
  std::vector<unsigned char> glb() const {
    json d = doc;
    d["buffers"] = json::array({{{"byteLength", bin.size()}}});
    std::string text = d.dump();
    while (text.size() % 4) text += ' ';
    std::vector<unsigned char> b, padded = bin;
    while (padded.size() % 4) padded.push_back(0);
    put<std::uint32_t>(b, 0x46546C67);
    put<std::uint32_t>(b, 2);
    put<std::uint32_t>(b, std::uint32_t(12 + 8 + text.size() + 8 + padded.size()));
    put<std::uint32_t>(b, std::uint32_t(text.size()));
    put<std::uint32_t>(b, 0x4E4F534A);
    testing::put_text(b, text);
    put<std::uint32_t>(b, std::uint32_t(padded.size()));
    put<std::uint32_t>(b, 0x004E4942);
    b.insert(b.end(), padded.begin(), padded.end());
    return b;
  }
};

const std::vector<Float3> kQuad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};

// A unit quad instanced by three nodes of the default scene:
//  node 0: translate (10,0,0), children 1 and 2
//  node 1: scale 2                          → x [10,12], y [0,2]
//  node 2: matrix = translate (0,5,0) · rotate 90° about z → x [9,10], y [5,6]
//  node 3 (a root): translate (0,0,-3) · quaternion 90° about x → x [0,1], y 0, z [-3,-2]
//  node 4 (not in the scene) is never emitted.
Builder hierarchy() {
  Builder b;
  const int pos = b.positions(kQuad);  // bytes 0-47 (accessor 0); indices bytes 48-59
  const int m = b.mesh({Builder::primitive(pos, b.indices({0, 1, 2, 0, 2, 3}), -1, 1)});
  const double s = std::sqrt(0.5);
  b.doc["nodes"] = json::array({
      {{"translation", {10, 0, 0}}, {"children", {1, 2}}},
      {{"scale", {2, 2, 2}}, {"mesh", m}},
      {{"matrix", {0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 0, 5, 0, 1}}, {"mesh", m}},
      {{"translation", {0, 0, -3}}, {"rotation", {s, 0, 0, s}}, {"mesh", m}},
      {{"translation", {100, 100, 100}}, {"mesh", m}},
  });
  b.doc["scenes"] = json::array({{{"nodes", {0, 3}}}});
  b.doc["scene"] = 0;
  return b;
}

class Gltf : public testing::TempDir {
 protected:
  ImportStats stats(const std::string& p) { return mesh_file_stats(p); }
};

TEST_F(Gltf, ExternalBinFlattensNodeHierarchy) {
  Builder b = hierarchy();
  write("scene.bin", b.bin);
  const auto p = write("scene.gltf", b.gltf("scene.bin"));
  std::vector<Triangle> tris;
  const auto st = stream_gltf(p, {}, [&](std::span<const Triangle> t) { tris.insert(tris.end(), t.begin(), t.end()); });
  ASSERT_TRUE(st.has_value());
  EXPECT_EQ(st->triangles, 6u);
  EXPECT_EQ(st->skipped_primitives, 0u);
  expect_bounds(st->bounds, {0, 0, -3}, {12, 6, 0});
  for (auto& t : tris) EXPECT_EQ(t.material, 1u);
  // Node 2: (1,0,0) → rotate → (0,1,0) → +(0,5,0) → +(10,0,0).
  EXPECT_NEAR(tris[2].v1.x, 10, 1e-5f);
  EXPECT_NEAR(tris[2].v1.y, 6, 1e-5f);
  // The import transform applies after the node transforms.
  const ImportStats moved = mesh_file_stats(p, Affine::translate({0, 0, 10}));
  expect_bounds(moved.bounds, {0, 0, 7}, {12, 6, 10});
}

TEST_F(Gltf, UriWithPercentEscapes) {
  Builder b = hierarchy();
  write("my mesh.bin", b.bin);
  EXPECT_EQ(stats(write("m.gltf", b.gltf("my%20mesh.bin"))).triangles, 6u);
}

// The files a glTF reads or names (kept from being replaced by outputs, apps/cmd_render.cpp):
// external buffers and images, percent-decoded beside the document; not data: URIs, not a
// .glb's own BIN chunk; what a damaged document still names.
TEST_F(Gltf, ExternalFilesAreItsBuffersAndImages) {
  Builder b = hierarchy();
  std::string text = b.gltf("my%20mesh.bin");
  json d = json::parse(text);
  d["images"] = json::array({{{"uri", "tex/wood.png"}}, {{"uri", "data:image/png;base64,AAAA"}}, {{"bufferView", 0}}});
  const auto p = write("m.gltf", d.dump());
  const auto dir = std::filesystem::path(p).parent_path();
  EXPECT_EQ(gltf_external_files(p), (std::vector<std::string>{(dir / "my mesh.bin").string(), (dir / "tex/wood.png").string()}));
  EXPECT_TRUE(gltf_external_files(write("e.gltf", b.gltf(""))).empty());
  EXPECT_TRUE(gltf_external_files(write("m.glb", b.glb())).empty());
  EXPECT_TRUE(gltf_external_files(write("bad.gltf", "{\"buffers\": [")).empty());
  EXPECT_TRUE(gltf_external_files((dir / "absent.gltf").string()).empty());
}

TEST_F(Gltf, GlbAndDataUriGiveTheSameResult) {
  Builder b = hierarchy();
  for (const auto& p : {write("m.glb", b.glb()), write("d.gltf", b.gltf(""))}) {
    SCOPED_TRACE(p);
    const ImportStats s = stats(p);
    EXPECT_EQ(s.triangles, 6u);
    expect_bounds(s.bounds, {0, 0, -3}, {12, 6, 0});
  }
}

TEST_F(Gltf, EveryPrimitiveModeAndSkippedCounts) {
  Builder b;
  std::vector<Float3> line;
  for (int i = 0; i < 7; ++i) line.push_back({float(i), float(i % 2), 0});
  const int seven = b.positions(line);
  const int four = b.positions(kQuad);
  const int m = b.mesh({
      Builder::primitive(seven),                                     // TRIANGLES, 7 vertices: 2 + 1 skipped
      Builder::primitive(seven, b.indices({0, 1, 2, 3, 4}, 5121), 5),  // strip: 3
      Builder::primitive(seven, -1, 6),                              // fan, 7 vertices: 5
      Builder::primitive(four, -1, 0),                               // 4 points
      Builder::primitive(seven, b.indices({0, 1, 2, 3, 4, 5}, 5125), 1),  // 3 lines
      Builder::primitive(four, -1, 2),                               // loop: 4 segments
      Builder::primitive(four, -1, 3),                               // strip: 3 segments
      Builder::primitive(-1),                                        // no POSITION: 1
  });
  b.doc["nodes"] = json::array({{{"mesh", m}}});
  b.doc["scenes"] = json::array({{{"nodes", {0}}}});
  std::vector<Triangle> tris;
  const auto st = stream_gltf(write("modes.gltf", b.gltf("")), {},
                              [&](std::span<const Triangle> t) { tris.insert(tris.end(), t.begin(), t.end()); });
  ASSERT_TRUE(st.has_value());
  EXPECT_EQ(st->triangles, 10u);
  EXPECT_EQ(st->skipped_primitives, 1u + 4 + 3 + 4 + 3 + 1);
  ASSERT_EQ(tris.size(), 10u);
  // Strip: (0,1,2), (1,3,2), (2,3,4): the second keeps the winding.
  EXPECT_EQ(tris[3].v0, line[1]);
  EXPECT_EQ(tris[3].v1, line[3]);
  EXPECT_EQ(tris[3].v2, line[2]);
  // Fan: p_i = (v_{i+1}, v_{i+2}, v_0).
  EXPECT_EQ(tris[5].v0, line[1]);
  EXPECT_EQ(tris[5].v2, line[0]);
  EXPECT_EQ(tris[9].v1, line[6]);
}

TEST_F(Gltf, QuantizedInterleavedPositions) {
  Builder b;
  // Interleaved: int16 x, y, z + 2 bytes of padding per vertex, stride 8, normalized.
  std::vector<unsigned char> data;
  for (auto& v : std::vector<std::array<std::int16_t, 3>>{{0, 0, 0}, {32767, 0, 0}, {0, -32767, 16384}}) {
    for (auto c : v) put<std::int16_t>(data, c);
    put<std::int16_t>(data, 0);
  }
  const int view = b.view(data, 8);
  const int pos = b.accessor(view, 5122, 3, "VEC3", 0, true);
  const int m = b.mesh({Builder::primitive(pos, b.indices({0, 1, 2}, 5121))});
  b.doc["nodes"] = json::array({{{"mesh", m}}});
  b.doc["extensionsRequired"] = {"KHR_mesh_quantization"};
  const ImportStats s = stats(write("q.gltf", b.gltf("")));
  EXPECT_EQ(s.triangles, 1u);
  expect_bounds(s.bounds, {0, -1, 0}, {1, 0, 16384.0f / 32767});
}

TEST_F(Gltf, WithoutScenesEveryRootNodeAndWithoutNodesEveryMesh) {
  Builder b;
  const int pos = b.positions(kQuad);
  const int m = b.mesh({Builder::primitive(pos, b.indices({0, 1, 2, 0, 2, 3}))});
  b.doc["nodes"] = json::array({{{"translation", {5, 0, 0}}, {"children", {1}}}, {{"mesh", m}}, {{"mesh", m}}});
  ImportStats s = stats(write("roots.gltf", b.gltf("")));
  EXPECT_EQ(s.triangles, 4u);  // node 1 via node 0, and node 2
  expect_bounds(s.bounds, {0, 0, 0}, {6, 1, 0});
  b.doc.erase("nodes");
  s = stats(write("meshes.gltf", b.gltf("")));
  EXPECT_EQ(s.triangles, 2u);
}

TEST_F(Gltf, SparseAccessorsGoToAssimp) {
  Builder b = hierarchy();
  b.doc["accessors"][0]["sparse"] = {{"count", 1},
                                     {"indices", {{"bufferView", 1}, {"componentType", 5123}}},
                                     {"values", {{"bufferView", 0}}}};
  const auto p = write("sparse.gltf", b.gltf(""));
  EXPECT_FALSE(stream_gltf(p, {}, [](std::span<const Triangle>) {}).has_value());
  // mesh_import then asks assimp; whatever it makes of the file, the result is triangles
  // or an InputError, never a crash.
  try {
    EXPECT_GT(stats(p).triangles, 0u);
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), p);
  }
}

TEST_F(Gltf, Errors) {
  Builder good = hierarchy();
  const auto gtf = [&](const std::string& name, Builder b) { return write(name, b.gltf("")); };

  auto glb = good.glb();
  glb.resize(glb.size() - 10);
  auto p = write("cut.glb", glb);
  expect_error([&] { stats(p); }, p, "glb header", "(truncated)");
  glb = good.glb();
  glb[4] = 3;
  p = write("v3.glb", glb);
  expect_error([&] { stats(p); }, p, "glb header", "unsupported GLB version 3");
  p = write("short.glb", std::string("glTF\x02\0\0\0", 8));
  expect_error([&] { stats(p); }, p, "glb header", "truncated GLB");

  Builder b = good;
  b.bin[48 + 4] = 7;  // third index of the quad: 7 ≥ 4 vertices
  p = gtf("index.gltf", b);
  expect_error([&] { stats(p); }, p, "meshes[0].primitives[0].indices", "index 7 (element 2) out of range (4 vertices)");

  b = good;
  b.doc["accessors"][0]["count"] = 5;
  p = gtf("acc.gltf", b);
  expect_error([&] { stats(p); }, p, "accessors[0]", "5 elements from byte 0 need 60 bytes but bufferViews[0] has 48");

  b = good;
  b.doc["bufferViews"][1]["byteLength"] = 100;
  p = gtf("view.gltf", b);
  expect_error([&] { stats(p); }, p, "bufferViews[1]", "outside its buffer of 60 bytes");

  p = write("missing.gltf", good.gltf("nowhere.bin"));
  expect_error([&] { stats(p); }, p, "buffers[0].uri", "cannot read");
  write("short.bin", std::vector<unsigned char>(good.bin.begin(), good.bin.begin() + 20));
  p = write("shortbin.gltf", good.gltf("short.bin"));
  expect_error([&] { stats(p); }, p, "buffers[0]", "byteLength is 60 but the data has 20 bytes (truncated)");

  p = write("json.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [");
  expect_error([&] { stats(p); }, p, "json", "parse error");

  b = good;
  b.doc["accessors"][0]["type"] = "VEC2";
  p = gtf("type.gltf", b);
  expect_error([&] { stats(p); }, p, "accessors[0].type", "POSITION must be VEC3");

  b = good;
  b.doc["meshes"][0]["primitives"][0]["mode"] = 9;
  p = gtf("mode.gltf", b);
  expect_error([&] { stats(p); }, p, "meshes[0].primitives[0].mode", "unknown primitive mode 9");

  b = good;
  b.doc["nodes"][1]["mesh"] = 5;
  p = gtf("mesh.gltf", b);
  expect_error([&] { stats(p); }, p, "nodes[1].mesh", "index 5 out of range (1)");

  b = good;
  b.doc["nodes"][1]["children"] = {0};
  p = gtf("cycle.gltf", b);
  expect_error([&] { stats(p); }, p, "nodes[1].children", "cycle");

  b = good;
  b.doc["asset"]["version"] = "3.0";
  p = gtf("version.gltf", b);
  expect_error([&] { stats(p); }, p, "asset.version", "unsupported glTF version '3.0'");
}

// Indices into the document's arrays and byte counts are attacker-chosen: every one out
// of range, or large enough to overflow 64-bit offset arithmetic, is an InputError naming
// the field (native reader), or at worst assimp's refusal (sparse accessors), never a crash.
constexpr std::uint64_t kMax = ~std::uint64_t(0);

TEST_F(Gltf, IndicesAndCountsOutOfRange) {
  const Builder good = hierarchy();
  const auto gtf = [&](const std::string& name, Builder b) { return write(name, b.gltf("")); };
  const struct {
    const char* name;
    void (*edit)(json&);
    const char* field;
  } cases[] = {
      {"view_index.gltf", [](json& d) { d["accessors"][0]["bufferView"] = 99; }, "accessors[0].bufferView"},
      {"buffer_index.gltf", [](json& d) { d["bufferViews"][0]["buffer"] = 7; }, "buffers[7]"},
      {"accessor_index.gltf", [](json& d) { d["meshes"][0]["primitives"][0]["indices"] = 42; }, "accessors[42]"},
      {"position_index.gltf", [](json& d) { d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = kMax; },
       "accessors[18446744073709551615]"},
      {"count.gltf", [](json& d) { d["accessors"][0]["count"] = kMax; }, "accessors[0]"},
      {"offset.gltf", [](json& d) { d["accessors"][0]["byteOffset"] = kMax; }, "accessors[0]"},
      {"view_offset.gltf", [](json& d) { d["bufferViews"][0]["byteOffset"] = kMax; }, "bufferViews[0]"},
      {"view_length.gltf", [](json& d) { d["bufferViews"][0]["byteLength"] = kMax; }, "bufferViews[0]"},
      {"stride.gltf", [](json& d) { d["bufferViews"][0]["byteStride"] = kMax; }, "accessors[0]"},
      {"scene_index.gltf", [](json& d) { d["scene"] = 5; }, "scene"},
      {"node_index.gltf", [](json& d) { d["nodes"][0]["children"] = {kMax}; }, "nodes[0].children"},
  };
  for (const auto& c : cases) {
    Builder b = good;
    c.edit(b.doc);
    const std::string p = gtf(c.name, b);
    try {
      stats(p);
      ADD_FAILURE() << c.name << ": no InputError";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), p) << e.what();
      EXPECT_EQ(e.field(), c.field) << e.what();
    }
  }
  // A sparse accessor (assimp's path) whose indices point past the vertices.
  Builder b = good;
  b.doc["accessors"][0]["sparse"] = {{"count", 1},
                                     {"indices", {{"bufferView", 1}, {"componentType", 5123}, {"byteOffset", 0}}},
                                     {"values", {{"bufferView", 0}}}};
  b.doc["accessors"][1]["count"] = 6;
  b.bin[48 + 4] = 200;
  const std::string p = gtf("sparse_bad.gltf", b);
  try {
    stats(p);
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), p);
  }
}

}  // namespace
}  // namespace rayline::scene

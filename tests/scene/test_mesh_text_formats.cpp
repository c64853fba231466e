// Native streaming readers for the text formats (OBJ, OFF, ASCII PLY, ASCII STL) and the
// generalised binary PLY reader: counts, skipped primitives, bounds and material slots on
// the hand-written fixtures in tests/data/meshes/, and InputError with the file and a
// useful field for every kind of malformed input.
#include <gtest/gtest.h>

#include <map>

#include "render/scene/mesh_import.hpp"
#include "render/scene/obj_reader.hpp"
#include "render/scene/off_reader.hpp"
#include "render/scene/ply_reader.hpp"
#include "render/scene/stl_reader.hpp"
#include "scene_fixture.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

using testing::put;
using testing::put_text;

std::string fixture(const std::string& name) { return std::string(RAYLINE_TEST_DATA) + "/meshes/" + name; }

void expect_bounds(const Bounds& b, Float3 lo, Float3 hi) {
  EXPECT_NEAR(b.lo.x, lo.x, 1e-5f); EXPECT_NEAR(b.lo.y, lo.y, 1e-5f); EXPECT_NEAR(b.lo.z, lo.z, 1e-5f);
  EXPECT_NEAR(b.hi.x, hi.x, 1e-5f); EXPECT_NEAR(b.hi.y, hi.y, 1e-5f); EXPECT_NEAR(b.hi.z, hi.z, 1e-5f);
}

struct Result {
  ImportStats st;
  std::vector<Triangle> tris;
  std::size_t batches = 0;
};
template <class Reader>
Result collect(Reader&& read) {
  Result r;
  r.st = read([&](std::span<const Triangle> b) {
    ++r.batches;
    r.tris.insert(r.tris.end(), b.begin(), b.end());
  });
  EXPECT_EQ(r.tris.size(), r.st.triangles);
  return r;
}
Result import(const std::string& path) {
  return collect([&](const TriangleBatchFn& fn) { return stream_mesh_file(path, {}, fn); });
}
std::map<std::uint32_t, int> per_material(const Result& r) {
  std::map<std::uint32_t, int> m;
  for (auto& t : r.tris) ++m[t.material];
  return m;
}

// Runs `f`, expecting InputError(file, field) whose text contains `text`.
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
void expect_import_error(const std::string& file, const std::string& field, const std::string& text = "") {
  expect_error([&] { mesh_file_stats(file); }, file, field, text);
}

class TextFormats : public testing::TempDir {};

// ---- OBJ -------------------------------------------------------------------------------

TEST_F(TextFormats, ObjFaceFormsNegativeIndicesPolygonsAndSlots) {
  const Result r = import(fixture("mixed.obj"));
  EXPECT_EQ(r.st.triangles, 8u);
  EXPECT_EQ(r.st.skipped_primitives, 5u);  // 2 line segments, 2 points, a 2-vertex face
  expect_bounds(r.st.bounds, {0, 0, 0}, {2, 2, 2});
  EXPECT_EQ(per_material(r), (std::map<std::uint32_t, int>{{0, 2}, {1, 3}, {2, 3}}));
  // The relative face "f -3 -2 -1" right after v5..v7.
  EXPECT_EQ(r.tris[2].v0, (Float3{0, 0, 2}));
  EXPECT_EQ(r.tris[2].v1, (Float3{2, 0, 2}));
  EXPECT_EQ(r.tris[2].v2, (Float3{2, 2, 2}));
  // The pentagon is fanned from its first vertex.
  EXPECT_EQ(r.tris[3].v0, (Float3{0, 0, 0}));
  EXPECT_EQ(r.tris[5].v2, (Float3{0, 1, 0}));
}

TEST_F(TextFormats, ObjFacesBeforeTheirVerticesTakeASecondPass) {
  const Result r = import(fixture("forward.obj"));
  EXPECT_EQ(r.st.triangles, 3u);
  expect_bounds(r.st.bounds, {0, 0, 0}, {3, 1, 0});
}

TEST_F(TextFormats, ObjCrlfTabsAndNoFinalNewlineAndSmallBatches) {
  std::string s;
  for (int i = 0; i < 10; ++i) s += "v\t" + std::to_string(i) + " 0 0\r\nv " + std::to_string(i) + " 1 0\r\n";
  for (int i = 0; i < 9; ++i) s += "f -4 -3 -1 -2\r\n";  // all relative to the end: the same quad
  s += "f 1 2 3";                                         // no final newline
  const auto p = write("crlf.obj", s);
  const Result r = collect([&](const TriangleBatchFn& fn) { return stream_obj(p, {}, fn, 4); });
  EXPECT_EQ(r.st.triangles, 19u);
  EXPECT_EQ(r.batches, 5u);  // 4 + 4 + 4 + 4 + 3
  expect_bounds(r.st.bounds, {0, 0, 0}, {9, 1, 0});
}

TEST_F(TextFormats, ObjTransformIsApplied) {
  const ImportStats s = mesh_file_stats(fixture("mixed.obj"), Affine::translate({1, 2, 3}) * Affine::scale({2, 2, 2}));
  expect_bounds(s.bounds, {1, 2, 3}, {5, 6, 7});
}

TEST_F(TextFormats, ObjErrorsNameTheLine) {
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  auto p = write("zero.obj", v + "f 1 2 0\n");
  expect_import_error(p, "line 4", "face index 0");
  p = write("range.obj", v + "f 1 2 3\nf 1 2 9\n");
  expect_import_error(p, "line 5", "face index 9 out of range (3 vertices");
  p = write("before.obj", v + "f -1 -2 -4\n");
  expect_import_error(p, "line 4", "reaches before the first vertex");
  p = write("vertex.obj", "v 0 0 0\nv 1 zero 0\n");
  expect_import_error(p, "line 2", "vertex 2: expected 3 numbers");
  p = write("short.obj", "v 0 0\n");
  expect_import_error(p, "line 1", "expected 3 numbers");
  p = write("token.obj", v + "f 1 2 x3\n");
  expect_import_error(p, "line 4", "bad face index 'x3'");
  p = write("nan.obj", "v 0 nan 0\n");
  expect_import_error(p, "line 1", "non-finite");
  // No faces at all: an error naming the file.
  p = write("nofaces.obj", v + "l 1 2\n");
  expect_import_error(p, "", "no triangles found (1 non-triangle primitives skipped)");
}

// ---- OFF -------------------------------------------------------------------------------

TEST_F(TextFormats, OffColoursCommentsPolygons) {
  const Result r = import(fixture("colored.off"));
  EXPECT_EQ(r.st.triangles, 4u);
  EXPECT_EQ(r.st.skipped_primitives, 1u);
  expect_bounds(r.st.bounds, {0, 0, -2}, {1, 1, 3});
}

TEST_F(TextFormats, OffHeaderVariants) {
  const std::string body = "0 0 0\n1 0 0\n1 1 0\n0 1 4\n4 0 1 2 3\n3 0 1 3\n";
  for (const std::string head : {"OFF\n4 2 0\n", "OFF 4 2 0\n", "OFF4 2 0\n", "4 2\n", "NOFF\n# c\n\n4 2 0\n", "STCOFF 4 2\n"}) {
    SCOPED_TRACE(head);
    const ImportStats s = stream_off(write("v.off", head + body), {}, [](std::span<const Triangle>) {});
    EXPECT_EQ(s.triangles, 3u);
    expect_bounds(s.bounds, {0, 0, 0}, {1, 1, 4});
  }
  // Homogeneous coordinates are divided by w.
  const ImportStats s = mesh_file_stats(write("h.off", "4OFF\n3 1 0\n0 0 0 1\n2 0 0 2\n0 4 0 0.5\n3 0 1 2\n"));
  expect_bounds(s.bounds, {0, 0, 0}, {1, 8, 0});
}

TEST_F(TextFormats, OffErrors) {
  const std::string v = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";
  auto p = write("trunc.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  expect_import_error(p, "face_count", "says 2 faces but the file ends after 1 (truncated)");
  p = write("truncv.off", "OFF\n4 0 0\n0 0 0\n1 0 0\n0 1 0\n");
  expect_import_error(p, "vertex_count", "says 4 vertices but the file ends after 3");
  p = write("index.off", v + "3 0 1 3\n");
  expect_import_error(p, "line 6", "vertex index 3 out of range (3 vertices)");
  p = write("negative.off", v + "3 0 -1 2\n");
  expect_import_error(p, "line 6", "vertex index -1 out of range");
  p = write("few.off", v + "3 0 1\n");
  expect_import_error(p, "line 6", "expected 3 vertex indices");
  p = write("count.off", "OFF\n3000000 1 0\n0 0 0\n");
  expect_import_error(p, "header", "more than a file of");
  p = write("negcount.off", "OFF\n-3 1 0\n");
  expect_import_error(p, "header", "negative");
  p = write("badcount.off", "OFF\nthree 1 0\n");
  expect_import_error(p, "header", "bad count 'three'");
  p = write("keyword.off", "OFX\n3 1 0\n");
  expect_import_error(p, "header", "not an OFF file");
  p = write("binary.off", "OFF BINARY\n3 1 0\n");
  expect_import_error(p, "header", "binary OFF");
  p = write("vertex.off", "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n");
  expect_import_error(p, "line 4", "vertex 1: expected 3 numbers");
}

// ---- PLY -------------------------------------------------------------------------------

TEST_F(TextFormats, AsciiPlyExtraPropertiesElementsAndLists) {
  const std::string f = fixture("ascii.ply");
  const PlyHeaderInfo h = read_ply_header(f);
  EXPECT_FALSE(h.binary);
  EXPECT_TRUE(h.streamable);
  EXPECT_EQ(h.vertices, 6u);
  EXPECT_EQ(h.faces, 4u);
  const Result r = import(f);
  EXPECT_EQ(r.st.triangles, 4u);
  EXPECT_EQ(r.st.skipped_primitives, 1u);
  expect_bounds(r.st.bounds, {-1, 0, 0}, {2, 3, 4});
  EXPECT_EQ(per_material(r), (std::map<std::uint32_t, int>{{0, 3}, {2, 1}}));
  EXPECT_EQ(r.tris[3].v2, (Float3{1.5f, 1, 0}));  // "+1.5e0 1 1e-50"
}

TEST_F(TextFormats, AsciiPlyFaceElementBeforeVertexElement) {
  const auto p = write("fv.ply",
                       "ply\nformat ascii 1.0\nelement face 2\nproperty list uchar int vertex_indices\n"
                       "element vertex 4\nproperty double x\nproperty double y\nproperty double z\nend_header\n"
                       "3 0 1 2\n3 0 2 3\n0 0 0\n1 0 0\n1 1 0\n0 1 -1\n");
  const Result r = import(p);
  EXPECT_EQ(r.st.triangles, 2u);
  expect_bounds(r.st.bounds, {0, 0, -1}, {1, 1, 0});
}

// Binary PLY with an element of variable size before the faces and a second list in the
// face element (texture coordinates), both byte orders.
std::vector<unsigned char> binary_ply_with_lists(bool big) {
  std::vector<unsigned char> b;
  put_text(b, std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                  "element polyline 2\nproperty list uchar int idx\n"
                  "element face 3\nproperty uchar flags\nproperty list uchar float texcoord\n"
                  "property list int uint vertex_indices\nproperty ushort material_index\nend_header\n");
  for (auto& v : {std::array<float, 3>{0, 0, 0}, {3, 0, 0}, {3, 2, 0}, {0, 2, -5}})
    for (float c : v) put<float>(b, c, big);
  put<std::uint8_t>(b, 3, big);
  for (int i : {0, 1, 2}) put<std::int32_t>(b, i, big);
  put<std::uint8_t>(b, 0, big);
  auto face = [&](std::vector<std::uint32_t> idx, std::uint16_t mat) {
    put<std::uint8_t>(b, 9, big);
    put<std::uint8_t>(b, 2, big);
    put<float>(b, 0.5f, big), put<float>(b, 0.25f, big);
    put<std::int32_t>(b, std::int32_t(idx.size()), big);
    for (auto i : idx) put<std::uint32_t>(b, i, big);
    put<std::uint16_t>(b, mat, big);
  };
  face({0, 1, 2, 3}, 1);
  face({0, 1}, 0);
  face({0, 2, 3}, 4);
  return b;
}

TEST_F(TextFormats, BinaryPlyBothByteOrdersWithVariableElementsAndExtraLists) {
  for (bool big : {false, true}) {
    SCOPED_TRACE(big ? "big endian" : "little endian");
    const auto p = write(big ? "be.ply" : "le.ply", binary_ply_with_lists(big));
    EXPECT_TRUE(read_ply_header(p).streamable);
    const Result r = import(p);
    EXPECT_EQ(r.st.triangles, 3u);
    EXPECT_EQ(r.st.skipped_primitives, 1u);
    expect_bounds(r.st.bounds, {0, 0, -5}, {3, 2, 0});
    EXPECT_EQ(per_material(r), (std::map<std::uint32_t, int>{{1, 2}, {4, 1}}));
    // Truncated inside the face data.
    auto cut = binary_ply_with_lists(big);
    cut.resize(cut.size() - 7);
    const auto t = write("cut.ply", cut);
    expect_import_error(t, "face", "truncated");
  }
}

TEST_F(TextFormats, PlyErrors) {
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string verts = "0 0 0\n1 0 0\n0 1 0\n";
  auto p = write("trunc.ply", head + verts);
  expect_import_error(p, "face", "says 1 face elements but the file ends after 0 (truncated)");
  p = write("truncv.ply", head + "0 0 0\n");
  expect_import_error(p, "vertex", "truncated");
  p = write("index.ply", head + verts + "3 0 1 5\n");
  expect_import_error(p, "line 13", "face 0: vertex index 5 out of range (3 vertices)");
  p = write("value.ply", head + "0 0 0\n1 oops 0\n0 1 0\n3 0 1 2\n");
  expect_import_error(p, "line 11", "vertex 1: bad or missing value for property 'y'");
  p = write("list.ply", head + verts + "4 0 1 2\n");
  expect_import_error(p, "line 13", "face 0: bad or missing value for property 'vertex_indices'");
  auto big = head;
  big.replace(big.find("vertex 3"), 8, "vertex 3000000000");
  p = write("count.ply", big + verts + "3 0 1 2\n");
  expect_import_error(p, "header.element", "more than a file of");
  p = write("noend.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
  expect_import_error(p, "header", "no end_header");
  p = write("format.ply", "ply\nformat text 1.0\nend_header\n");
  expect_import_error(p, "header.format", "unknown PLY format");
  p = write("prop.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n");
  expect_import_error(p, "header.property", "malformed property line");
}

// ---- STL -------------------------------------------------------------------------------

TEST_F(TextFormats, AsciiStlSeveralSolidsUpperCaseAndPolygonLoops) {
  const std::string f = fixture("two_solids.stl");
  EXPECT_FALSE(is_binary_stl(f));
  const Result r = import(f);
  EXPECT_EQ(r.st.triangles, 3u);
  EXPECT_EQ(r.st.skipped_primitives, 1u);
  expect_bounds(r.st.bounds, {0, -3, 0}, {2, 1, 5});
}

TEST_F(TextFormats, AsciiStlErrors) {
  const std::string facet = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n";
  auto p = write("cut.stl", "solid a\n" + facet + "facet normal 0 0 1\nouter loop\nvertex 0 0 0\n");
  expect_import_error(p, "line 11", "file ends inside a facet (truncated)");
  p = write("noend.stl", "solid a\n" + facet);
  expect_import_error(p, "line 8", "without 'endsolid'");
  p = write("vertex.stl", "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n");
  expect_import_error(p, "line 4", "vertex: expected 3 numbers");
  p = write("keyword.stl", "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nendfacet\n");
  expect_import_error(p, "line 5", "unexpected 'endfacet'");
  p = write("header.stl", "hello\n" + facet);
  expect_error([&] { stream_ascii_stl(p, {}, [](std::span<const Triangle>) {}); }, p, "header", "not an ASCII STL");
  // A binary STL whose 80-byte header starts with "solid" and whose size does not match
  // its count is reported as a binary STL, not as a broken ASCII one.
  std::vector<unsigned char> b(80, ' ');
  std::memcpy(b.data(), "solid x", 7);
  put<std::uint32_t>(b, 2);
  b.resize(84 + 60);
  p = write("binsolid.stl", b);
  expect_import_error(p, "triangle_count", "header says 2 triangles");
}

}  // namespace
}  // namespace rayline::scene

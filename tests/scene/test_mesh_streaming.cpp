// Streaming properties of the native mesh readers: bounded memory on multi-million-
// triangle text meshes, the same triangles as assimp on small fixtures, and the
// disk-backed vertex spill they use.
#include <gtest/gtest.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <malloc.h>
#include <sys/resource.h>

#include "render/scene/mesh_import.hpp"
#include "render/scene/spill_file.hpp"
#include "scene_fixture.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

std::string fixture(const std::string& name) { return std::string(RAYLINE_TEST_DATA) + "/meshes/" + name; }

// ---- bounded memory --------------------------------------------------------------------

// Buffered text writer (std::to_chars, 1 MiB chunks) for the big generated meshes.
class Writer {
 public:
  explicit Writer(const std::string& path) : f_(std::fopen(path.c_str(), "wb")) { buf_.reserve(kChunk + 256); }
  ~Writer() {
    flush();
    std::fclose(f_);
  }
  Writer& operator<<(const char* s) {
    buf_ += s;
    return *this;
  }
  Writer& operator<<(float v) { return num(v); }
  Writer& operator<<(std::uint64_t v) { return num(v); }
  void end_line() {
    buf_ += '\n';
    if (buf_.size() > kChunk) flush();
  }

 private:
  static constexpr std::size_t kChunk = 1 << 20;
  template <class T>
  Writer& num(T v) {
    char tmp[32];
    const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
    buf_.append(tmp, r.ptr);
    return *this;
  }
  void flush() {
    std::fwrite(buf_.data(), 1, buf_.size(), f_);
    buf_.clear();
  }
  std::FILE* f_;
  std::string buf_;
};

// An n × n vertex grid on a gently curved surface: 2 (n-1)² triangles. OBJ writes quads
// (fanned by the reader), PLY writes triangles.
void write_grid(const std::string& path, std::uint64_t n, bool ply) {
  Writer w(path);
  const std::uint64_t quads = (n - 1) * (n - 1);
  if (ply) {
    w << "ply\nformat ascii 1.0\nelement vertex " << n * n << "\nproperty float x\nproperty float y\nproperty float z\n"
      << "element face " << 2 * quads << "\nproperty list uchar int vertex_indices\nend_header\n";
  }
  for (std::uint64_t j = 0; j < n; ++j)
    for (std::uint64_t i = 0; i < n; ++i) {
      const float x = float(i) / float(n - 1), y = float(j) / float(n - 1);
      if (!ply) w << "v ";
      w << x << " " << y << " " << 0.25f * x * (1 - x) + 0.125f * y;
      w.end_line();
    }
  const std::uint64_t base = ply ? 0 : 1;
  for (std::uint64_t j = 0; j + 1 < n; ++j)
    for (std::uint64_t i = 0; i + 1 < n; ++i) {
      const std::uint64_t a = j * n + i + base, b = a + 1, c = a + n + 1, d = a + n;
      if (ply) {
        w << "3 " << a << " " << b << " " << c;
        w.end_line();
        w << "3 " << a << " " << c << " " << d;
      } else {
        w << "f " << a << " " << b << " " << c << " " << d;
      }
      w.end_line();
    }
}

// Live glibc heap bytes: small chunks in use (uordblks) plus mmapped big chunks (hblkhd).
std::size_t heap_in_use() {
  const struct mallinfo2 m = ::mallinfo2();
  return m.uordblks + m.hblkhd;
}
std::size_t max_rss_bytes() {
  struct rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  return std::size_t(u.ru_maxrss) * 1024;
}

class Streaming : public testing::TempDir {
 protected:
  // Streams a generated ≈2 M-triangle mesh and checks that memory stays far below the
  // mesh size. Two measures, both robust to what ran before in this process (each TEST
  // is its own process under ctest, and the file is written before the baselines):
  //  * heap: mallinfo2's live bytes, sampled in every batch callback (where the reader's
  //    buffers are all alive) and after the import; the peak over the baseline must stay
  //    under 16 MiB — the line buffer (1 MiB) and one triangle batch (2.6 MB) — against
  //    72 MB for the triangles themselves (assimp holds several times that);
  //  * RSS: ru_maxrss, the process's peak resident set, which also counts the spilled
  //    vertices' mapped pages (12 MB here, dropped every 64 MiB of faces); growth must
  //    stay under 48 MiB, i.e. under the 62-72 MB text file and the 72 MB soup.
  void check_bounded(const std::string& name, bool ply) {
    const std::uint64_t n = 1001;  // 1 002 001 vertices, 2 000 000 triangles
    const std::string p = path(name);
    write_grid(p, n, ply);
    const std::uint64_t file_bytes = std::filesystem::file_size(p);
    const std::uint64_t expected = 2 * (n - 1) * (n - 1);
    const std::size_t heap0 = heap_in_use(), rss0 = max_rss_bytes();
    std::size_t heap_peak = heap0, batches = 0;
    std::uint64_t count = 0;
    const ImportStats st = stream_mesh_file(p, {}, [&](std::span<const Triangle> b) {
      count += b.size(), ++batches;
      heap_peak = std::max(heap_peak, heap_in_use());
    });
    heap_peak = std::max(heap_peak, heap_in_use());
    const std::size_t rss_growth = max_rss_bytes() - rss0;
    EXPECT_EQ(st.triangles, expected);
    EXPECT_EQ(count, expected);
    EXPECT_GT(batches, 10u);
    EXPECT_NEAR(st.bounds.hi.x, 1.0f, 1e-6f);
    EXPECT_NEAR(st.bounds.hi.y, 1.0f, 1e-6f);
    const double mesh_bytes = double(expected) * sizeof(Float3) * 3;
    std::printf("%s: %.1f MB file, %.1f MB of triangles; heap growth %.2f MiB, max RSS growth %.2f MiB\n",
                name.c_str(), double(file_bytes) / 1e6, mesh_bytes / 1e6, double(heap_peak - heap0) / 1048576.0,
                double(rss_growth) / 1048576.0);
    EXPECT_LT(heap_peak - heap0, std::size_t(16) << 20);
    EXPECT_LT(rss_growth, std::size_t(48) << 20);
    EXPECT_LT(double(rss_growth), mesh_bytes / 1.5);
  }
};

TEST_F(Streaming, ObjOfTwoMillionTrianglesInBoundedMemory) { check_bounded("grid.obj", false); }
TEST_F(Streaming, AsciiPlyOfTwoMillionTrianglesInBoundedMemory) { check_bounded("grid.ply", true); }

// ---- the same triangles as assimp ------------------------------------------------------

// Triangles as a sorted multiset; each rotated to start at its smallest vertex (winding
// kept), since assimp may start a triangle at another corner.
using Key = std::array<float, 9>;
std::vector<Key> multiset(const std::string& path, ImportPath route, ImportStats* st = nullptr) {
  std::vector<Key> keys;
  const ImportStats s = stream_mesh_file(path, {}, [&](std::span<const Triangle> b) {
    for (const Triangle& t : b) {
      std::array<Float3, 3> v = {t.v0, t.v1, t.v2};
      auto less = [](Float3 a, Float3 b) { return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z); };
      const auto first = std::size_t(std::min_element(v.begin(), v.end(), less) - v.begin());
      std::rotate(v.begin(), v.begin() + long(first), v.end());
      keys.push_back({v[0].x, v[0].y, v[0].z, v[1].x, v[1].y, v[1].z, v[2].x, v[2].y, v[2].z});
    }
  }, route);
  if (st) *st = s;
  std::sort(keys.begin(), keys.end());
  return keys;
}

class Parity : public testing::TempDir {};

TEST_F(Parity, NativeReadersGiveAssimpsTriangles) {
  for (const char* f : {"parity.obj", "parity.off", "parity.ply", "parity.stl", "ascii.ply"}) {
    SCOPED_TRACE(f);
    ImportStats native_st, assimp_st;
    const auto native = multiset(fixture(f), ImportPath::automatic, &native_st);
    const auto assimp = multiset(fixture(f), ImportPath::assimp, &assimp_st);
    EXPECT_EQ(native.size(), std::string(f) == "ascii.ply" ? 4u : 6u);
    EXPECT_EQ(native, assimp);
    EXPECT_EQ(native_st.bounds.lo, assimp_st.bounds.lo);
    EXPECT_EQ(native_st.bounds.hi, assimp_st.bounds.hi);
  }
  // All the OBJ face forms: same counts and bounds (assimp clips the pentagon's ears
  // differently from the fan, so the triangles themselves differ). Assimp 5.2 rejects
  // the fixture's trailing comment after a face ("Invalid face index"), so it reads a
  // copy without it.
  std::string text = read(fixture("mixed.obj"));
  text.erase(text.find("   # trailing comment"), std::string("   # trailing comment; 1 triangle, slot 1").size());
  const auto stripped = write("mixed.obj", text);
  EXPECT_THROW(multiset(fixture("mixed.obj"), ImportPath::assimp), InputError);
  ImportStats a, b;
  multiset(fixture("mixed.obj"), ImportPath::automatic, &a);
  multiset(stripped, ImportPath::assimp, &b);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.skipped_primitives, b.skipped_primitives);
  EXPECT_EQ(a.bounds.lo, b.bounds.lo);
  EXPECT_EQ(a.bounds.hi, b.bounds.hi);
}

TEST_F(Parity, GltfWithNodeTransformsGivesAssimpsTriangles) {
  // A quad and a triangle; node 0 translates (10,0,0), its child node 1 scales by 2 and
  // holds mesh 0, node 2 (a root) holds mesh 1 untransformed.
  std::vector<unsigned char> bin;
  for (float c : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 1.f, 0.f, 0.f, 1.f, 0.f}) testing::put<float>(bin, c);
  for (std::uint16_t i : {0, 1, 2, 0, 2, 3}) testing::put<std::uint16_t>(bin, i);
  for (float c : {0.f, 0.f, 5.f, 0.f, 3.f, 5.f, -2.f, 0.f, 5.f}) testing::put<float>(bin, c);
  const std::string json =
      R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,2]}],)"
      R"("nodes":[{"translation":[10,0,0],"children":[1]},{"scale":[2,2,2],"mesh":0},{"mesh":1}],)"
      R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]},)"
      R"({"primitives":[{"attributes":{"POSITION":2}}]}],)"
      R"("accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},)"
      R"({"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"},)"
      R"({"bufferView":2,"componentType":5126,"count":3,"type":"VEC3","min":[-2,0,5],"max":[0,3,5]}],)"
      R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":12},)"
      R"({"buffer":0,"byteOffset":60,"byteLength":36}],)"
      R"("buffers":[{"uri":"p.bin","byteLength":96}]})";
  write("p.bin", bin);
  const auto p = write("p.gltf", json);
  const auto native = multiset(p, ImportPath::automatic), assimp = multiset(p, ImportPath::assimp);
  EXPECT_EQ(native.size(), 3u);
  EXPECT_EQ(native, assimp);
}

// ---- the vertex spill --------------------------------------------------------------------

class Spill : public testing::TempDir {};

TEST_F(Spill, GrowsKeepsContentsAndLeavesNoFile) {
  ::setenv("RAYLINE_SPILL_DIR", dir_.c_str(), 1);
  {
    SpillArray<Float3> a;
    const std::size_t n = 3'000'000;  // 36 MB: several growths (the mapping moves)
    for (std::size_t i = 0; i < n; ++i) {
      a.push_back({float(i), float(i % 7), -float(i)});
      if (i % 1'000'000 == 0) a.drop_resident();
    }
    a.drop_resident();
    ASSERT_EQ(a.size(), n);
    for (std::size_t i = 0; i < n; i += 997) ASSERT_EQ(a[i], (Float3{float(i), float(i % 7), -float(i)})) << i;
    EXPECT_EQ(a[n - 1].x, float(n - 1));
    // Anonymous: nothing in the folder, even while it is open.
    EXPECT_TRUE(std::filesystem::is_empty(dir_));
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir_));
}

TEST_F(Spill, UnusableDirectoryFallsBackToTheNext) {
  ::setenv("RAYLINE_SPILL_DIR", path("does-not-exist").c_str(), 1);
  ::setenv("TMPDIR", dir_.c_str(), 1);
  SpillFile f;
  EXPECT_EQ(f.directory(), dir_.string());
  const unsigned char bytes[3] = {1, 2, 42};
  f.write(97, bytes, 3);
  EXPECT_GE(f.capacity(), 100u);
  f.drop_resident();
  EXPECT_EQ(f.data()[99], 42);
  EXPECT_EQ(f.data()[98], 2);
}

}  // namespace
}  // namespace rayline::scene

// Streaming kd-tree partitioner and block files ("Blocks on disk").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <unistd.h>

#include "render/partition/partition.hpp"
#include "common/unfinished_output.hpp"
#include "common/error.hpp"

namespace fs = std::filesystem;
using namespace rayline::partition;
using rayline::InputError;
using rayline::scene::ImportStats;
using rayline::scene::TriangleBatchFn;

namespace {

class PartitionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("rayline-partition-" + std::string(info->name()) + "-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& n) const { return (dir_ / n).string(); }
  fs::path dir_;
};

// Deterministic triangle soup: small random triangles in [0,10]x[0,4]x[0,6], a few large
// ones crossing many cells, and a flat wall at x = 5 (stress = false: small ones only).
// material = triangle index (an id).
TriangleSource soup(std::uint32_t n, std::uint32_t seed = 7, bool stress = true) {
  return [n, seed, stress](const TriangleBatchFn& fn) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0, 1);
    std::vector<Triangle> batch;
    ImportStats st;
    for (std::uint32_t i = 0; i < n; ++i) {
      Triangle t;
      if (stress && i % 997 == 0) {  // large straddler
        t.v0 = {u(rng) * 10, u(rng) * 4, u(rng) * 6};
        t.v1 = {u(rng) * 10, u(rng) * 4, u(rng) * 6};
        t.v2 = {u(rng) * 10, u(rng) * 4, u(rng) * 6};
      } else if (stress && i % 50 == 0) {  // flat wall in the plane x = 5
        const Float3 c{5, u(rng) * 4, u(rng) * 6};
        t.v0 = c, t.v1 = {5, c.y + 0.05f, c.z}, t.v2 = {5, c.y, c.z + 0.05f};
      } else {
        const Float3 c{u(rng) * 10, u(rng) * 4, u(rng) * 6};
        t.v0 = c, t.v1 = {c.x + 0.02f * u(rng), c.y + 0.02f, c.z}, t.v2 = {c.x, c.y, c.z + 0.02f * u(rng)};
      }
      t.material = i;
      batch.push_back(t);
      st.bounds.extend(t.v0), st.bounds.extend(t.v1), st.bounds.extend(t.v2);
      if (batch.size() == 1000) fn(batch), batch.clear();
    }
    if (!batch.empty()) fn(batch);
    st.triangles = n;
    return st;
  };
}

// AABB overlap, with the partitioner's eps band (partition.hpp) around `b`.
bool overlaps(const Bounds& a, const Bounds& b, float eps = 0) {
  for (int i = 0; i < 3; ++i)
    if (a.hi[i] < b.lo[i] - eps || b.hi[i] + eps < a.lo[i]) return false;
  return true;
}
float route_eps(const Bounds& root) {
  float m = 0;
  for (int i = 0; i < 3; ++i)
    m = std::max({m, root.hi[i] - root.lo[i], std::fabs(root.lo[i]), std::fabs(root.hi[i])});
  return 1e-5f * m;
}
Bounds tri_box(const Triangle& t) {
  Bounds b;
  b.extend(t.v0), b.extend(t.v1), b.extend(t.v2);
  return b;
}
double volume(const Bounds& b) {
  const Float3 e = b.extent();
  return double(e.x) * e.y * e.z;
}
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
void poke(const std::string& file, std::uint64_t offset, const std::vector<unsigned char>& bytes) {
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(std::streamoff(offset));
  f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

PartitionOptions blocks(std::uint32_t n) {
  PartitionOptions o;
  o.blocks = n;
  o.memory_limit = 64 << 20;
  return o;
}

}  // namespace

TEST_F(PartitionTest, EveryTriangleInSomeBlockAndBlockTrianglesOverlapTheirCell) {
  const std::uint32_t n = 20000;
  const auto r = partition_triangles(soup(n), "soup", path("out"), blocks(13));
  ASSERT_EQ(r.index.blocks.size(), 13u);
  EXPECT_EQ(r.index.scene_triangles, n);
  std::vector<int> seen(n, 0);
  std::uint64_t refs = 0;
  for (const BlockInfo& bi : r.index.blocks) {
    const BlockFile bf = read_block(path("out/" + bi.file));
    EXPECT_EQ(bf.header.block_id, bi.id);
    EXPECT_EQ(bf.header.block_count, 13u);
    EXPECT_EQ(bf.triangles.size(), bi.triangles);
    EXPECT_EQ(fs::file_size(path("out/" + bi.file)), bi.file_bytes);
    for (const Triangle& t : bf.triangles) {
      ASSERT_LT(t.material, n);
      ++seen[t.material];
      EXPECT_TRUE(overlaps(tri_box(t), bi.cell, route_eps(r.index.bounds))) << "block " << bi.id << " triangle " << t.material;
    }
    refs += bf.triangles.size();
  }
  EXPECT_EQ(refs, r.index.references);
  for (std::uint32_t i = 0; i < n; ++i) ASSERT_GE(seen[i], 1) << "triangle " << i << " in no block";
  // The flat wall lies in no split plane unless the tree chose x = 5: either way each
  // wall triangle is referenced once or twice, and large straddlers several times.
  EXPECT_GT(r.index.references, n);
  EXPECT_FALSE(fs::exists(rayline::unfinished::temp_name(path("out"), "partial")));
}

TEST_F(PartitionTest, TriangleCountsAreBalanced) {
  // Tolerance: every block within 10 % of the mean references. The sample holds all 20 000
  // centroids here, so splits are exact quantiles; the slack is for triangles straddling
  // split planes. (Large straddlers, as in the stress soup, add their copies on top.)
  for (std::uint32_t nb : {2u, 8u, 13u, 64u, 65u}) {
    std::string name = "b";
    name += std::to_string(nb);
    const auto r = partition_triangles(soup(20000, 7, false), "soup", path(name), blocks(nb));
    const double mean = double(r.index.references) / nb;
    for (const BlockInfo& b : r.index.blocks) {
      EXPECT_LT(double(b.triangles), 1.10 * mean) << nb << " blocks, block " << b.id;
      EXPECT_GT(double(b.triangles), 0.90 * mean) << nb << " blocks, block " << b.id;
    }
  }
}

TEST_F(PartitionTest, SampledSplitsStayBalanced) {
  // A 2 000-centroid sample for 100 000 triangles (reservoir): splits are estimated
  // quantiles; tolerance 25 % of the mean for 16 blocks (~125 samples per block).
  PartitionOptions o = blocks(16);
  o.sample_limit = 2000;
  const auto r = partition_triangles(soup(100000, 7, false), "soup", path("out"), o);
  EXPECT_EQ(r.sample_size, 2000u);
  const double mean = double(r.index.references) / 16;
  for (const BlockInfo& b : r.index.blocks) {
    EXPECT_LT(double(b.triangles), 1.25 * mean) << b.id;
    EXPECT_GT(double(b.triangles), 0.75 * mean) << b.id;
  }
}

TEST_F(PartitionTest, GeneratedMuseumIsBalanced) {
  rayline::scene::Scene sc = rayline::scene::default_scene();
  sc.source = "museum";
  sc.meshes.resize(1);
  sc.meshes[0].name = "museum";
  sc.meshes[0].file.clear();
  sc.meshes[0].generator = "museum-like";
  sc.meshes[0].triangles = 200000;
  sc.meshes[0].material_slots.clear();
  const auto r = partition_scene(sc, path("out"), blocks(16));
  EXPECT_GT(r.index.scene_triangles, 190000u);
  const double mean = double(r.index.references) / 16;
  for (const BlockInfo& b : r.index.blocks) {
    EXPECT_LT(double(b.triangles), 1.15 * mean) << b.id;
    EXPECT_GT(double(b.triangles), 0.85 * mean) << b.id;
  }
  EXPECT_LT(double(r.index.references), 1.10 * double(r.index.scene_triangles));
}

TEST_F(PartitionTest, CellsTileTheSceneBoundsWithoutOverlap) {
  const auto r = partition_triangles(soup(20000), "soup", path("out"), blocks(27));
  const auto& idx = r.index;
  double sum = 0;
  for (const BlockInfo& a : idx.blocks) {
    for (int i = 0; i < 3; ++i) {
      EXPECT_GE(a.cell.lo[i], idx.bounds.lo[i]);
      EXPECT_LE(a.cell.hi[i], idx.bounds.hi[i]);
    }
    sum += volume(a.cell);
    for (const BlockInfo& b : idx.blocks) {
      if (a.id >= b.id) continue;
      double ov = 1;
      for (int i = 0; i < 3; ++i)
        ov *= std::max(0.0, double(std::min(a.cell.hi[i], b.cell.hi[i])) - std::max(a.cell.lo[i], b.cell.lo[i]));
      EXPECT_EQ(ov, 0.0) << "cells " << a.id << " and " << b.id << " overlap";
    }
  }
  EXPECT_NEAR(sum, volume(idx.bounds), 1e-6 * volume(idx.bounds));
  // Points of the scene box fall in exactly the located cell.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0, 1);
  for (int k = 0; k < 2000; ++k) {
    const Float3 p{u(rng) * 10, u(rng) * 4, u(rng) * 6};
    const auto c = idx.blocks[idx.locate(p)].cell;
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(p[i] >= c.lo[i] && p[i] <= c.hi[i]);
  }
  // Neighbours: symmetric, touching, positive shared area; every cell has one.
  for (const BlockInfo& a : idx.blocks) {
    EXPECT_FALSE(a.neighbours.empty());
    for (const Neighbour& nb : a.neighbours) {
      const BlockInfo& b = idx.blocks[nb.block];
      EXPECT_GT(nb.area, 0);
      EXPECT_TRUE(a.cell.hi[nb.axis] == b.cell.lo[nb.axis] || b.cell.hi[nb.axis] == a.cell.lo[nb.axis]);
      EXPECT_TRUE(std::any_of(b.neighbours.begin(), b.neighbours.end(),
                              [&](const Neighbour& x) { return x.block == a.id && x.area == nb.area; }));
    }
  }
}

TEST_F(PartitionTest, CellsAlongRayAreOrderedAndComplete) {
  const auto r = partition_triangles(soup(20000), "soup", path("out"), blocks(33));
  const auto& idx = r.index;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int k = 0; k < 500; ++k) {
    const Float3 o{5 + 8 * u(rng), 2 + 4 * u(rng), 3 + 6 * u(rng)};
    const Float3 d = rayline::scene::normalize(Float3{u(rng), u(rng), u(rng)});
    const auto cells = idx.cells_along_ray(o, d, 0, 100);
    // Brute force: slab intervals of every cell, with positive length.
    std::vector<std::pair<float, std::uint32_t>> want;
    for (const BlockInfo& b : idx.blocks) {
      float t0 = 0, t1 = 100;
      for (int i = 0; i < 3; ++i) {
        float a = (b.cell.lo[i] - o[i]) / d[i], c = (b.cell.hi[i] - o[i]) / d[i];
        if (a > c) std::swap(a, c);
        t0 = std::max(t0, a), t1 = std::min(t1, c);
      }
      if (t1 - t0 > 1e-4f) want.push_back({t0, b.id});
    }
    std::sort(want.begin(), want.end());
    std::vector<std::uint32_t> got_pos;  // the positive-length cells in returned order
    std::set<std::uint32_t> wanted;
    for (auto& w : want) wanted.insert(w.second);
    for (auto c : cells)
      if (wanted.count(c)) got_pos.push_back(c);
    std::vector<std::uint32_t> want_ids;
    for (auto& w : want) want_ids.push_back(w.second);
    EXPECT_EQ(got_pos, want_ids) << "ray " << k;
  }
}

TEST_F(PartitionTest, OutputIsDeterministic) {
  partition_triangles(soup(20000), "soup", path("a"), blocks(9));
  partition_triangles(soup(20000), "soup", path("b"), blocks(9));
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(path("a"))) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  ASSERT_EQ(names.size(), 10u);  // 9 blocks + blocks.json
  for (const auto& n : names) EXPECT_EQ(slurp(path("a/" + n)), slurp(path("b/" + n))) << n;
}

TEST_F(PartitionTest, IndexRoundTripsThroughBlocksJson) {
  const auto r = partition_triangles(soup(5000), "soup", path("out"), blocks(6));
  const BlockIndex l = load_block_index(path("out"));
  EXPECT_EQ(block_index_to_json(l), block_index_to_json(r.index));
  ASSERT_EQ(l.nodes.size(), r.index.nodes.size());
  for (std::size_t i = 0; i < l.nodes.size(); ++i) {
    EXPECT_EQ(l.nodes[i].cell.lo, r.index.nodes[i].cell.lo);
    EXPECT_EQ(l.nodes[i].cell.hi, r.index.nodes[i].cell.hi);
  }
  for (const BlockInfo& b : l.blocks) {
    const BlockHeader h = read_block_header(path("out/" + b.file));
    EXPECT_EQ(h.payload_crc32, b.payload_crc32);
    EXPECT_EQ(h.cell.lo, b.cell.lo);
    EXPECT_EQ(h.cell.hi, b.cell.hi);
  }
}

TEST_F(PartitionTest, CorruptedOrTruncatedBlockIsAnInputErrorNamingFileAndField) {
  partition_triangles(soup(3000), "soup", path("out"), blocks(4));
  const std::string good = path("out/block_00001.rlb");
  const std::string orig = slurp(good);
  auto restore = [&] { std::ofstream(good, std::ios::binary | std::ios::trunc) << orig; };
  auto expect_error = [&](const std::string& field) {
    try {
      (void)read_block(good);
      ADD_FAILURE() << "no error, expected field " << field;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), good);
      EXPECT_EQ(e.field(), field) << e.what();
      EXPECT_NE(std::string(e.what()).find(good), std::string::npos);
    }
    restore();
  };
  ASSERT_NO_THROW((void)read_block(good));
  poke(good, 128 + 40 * 5 + 3, {0x5a});  // payload byte
  expect_error("payload_crc32");
  fs::resize_file(good, orig.size() - 17);  // truncated payload
  expect_error("payload_bytes");
  std::ofstream(good, std::ios::binary | std::ios::app) << "xx";  // trailing bytes
  expect_error("payload_bytes");
  fs::resize_file(good, 60);  // truncated header
  expect_error("header");
  fs::resize_file(good, 0);
  expect_error("header");
  poke(good, 0, {'X'});
  expect_error("magic");
  poke(good, 44, {0x01});  // cell bounds
  expect_error("header_checksum");
  {  // a newer version with a consistent header checksum
    BlockHeader h = read_block_header(good);
    h.version = 2;
    poke(good, 0, encode_block_header(h));
    expect_error("version");
  }
  {  // consistent header whose payload size disagrees with the file
    BlockHeader h = read_block_header(good);
    h.triangle_count += 1, h.payload_bytes += kRecordBytes;
    poke(good, 0, encode_block_header(h));
    expect_error("payload_bytes");
  }
  EXPECT_THROW((void)read_block(path("out/missing.rlb")), InputError);
}

TEST_F(PartitionTest, EdgeCasesOfBlockCounts) {
  // One block: the whole scene. More blocks than triangles: empty blocks are valid.
  auto r1 = partition_triangles(soup(100), "soup", path("one"), blocks(1));
  EXPECT_EQ(r1.index.blocks[0].triangles, 100u);
  EXPECT_EQ(r1.index.nodes.size(), 1u);
  auto r2 = partition_triangles(soup(5), "soup", path("many"), blocks(20));
  EXPECT_EQ(r2.index.blocks.size(), 20u);
  std::set<std::uint32_t> ids;
  for (const auto& b : r2.index.blocks)
    for (const auto& t : read_block(path("many/" + b.file)).triangles) ids.insert(t.material);
  EXPECT_EQ(ids.size(), 5u);
}

TEST_F(PartitionTest, BadInputsAreInputErrors) {
  EXPECT_THROW(partition_triangles(soup(0), "empty", path("e"), blocks(4)), InputError);
  auto nan_source = [](const TriangleBatchFn& fn) {
    Triangle t;
    t.v1 = {std::numeric_limits<float>::quiet_NaN(), 0, 0};
    fn(std::span<const Triangle>(&t, 1));
    return ImportStats{};
  };
  EXPECT_THROW(partition_triangles(nan_source, "nan", path("n"), blocks(4)), InputError);
  PartitionOptions tiny = blocks(100000);
  tiny.memory_limit = 16 << 20;
  EXPECT_THROW(partition_triangles(soup(10), "soup", path("t"), tiny), InputError);
  EXPECT_THROW(partition_triangles(soup(10), "soup", path("t"), blocks(0)), InputError);
  // Output folder: missing parent, a file, a foreign non-empty folder are refused.
  EXPECT_THROW(partition_triangles(soup(10), "soup", path("no/such/dir"), blocks(2)), InputError);
  std::ofstream(path("file")) << "x";
  EXPECT_THROW(partition_triangles(soup(10), "soup", path("file"), blocks(2)), InputError);
  fs::create_directories(path("foreign"));
  std::ofstream(path("foreign/keep.txt")) << "precious";
  EXPECT_THROW(partition_triangles(soup(10), "soup", path("foreign"), blocks(2)), InputError);
  EXPECT_TRUE(fs::exists(path("foreign/keep.txt")));
  // An earlier partition is replaced atomically, no partial folder left behind.
  partition_triangles(soup(100), "soup", path("p"), blocks(8));
  partition_triangles(soup(100), "soup", path("p"), blocks(3));
  EXPECT_EQ(load_block_index(path("p")).blocks.size(), 3u);
  EXPECT_FALSE(fs::exists(path("p/block_00007.rlb")));
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find(".partial."), std::string::npos) << e.path();
  // A damaged occupancy grid in blocks.json names the block and the field.
  const std::string index = path("p/blocks.json");
  std::string text;
  {
    std::ifstream in(index);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const auto at = text.find("\"bits\"");
  ASSERT_NE(at, std::string::npos) << "the partitioner writes occupancy grids";
  const auto digit = text.find('"', text.find(':', at)) + 1;
  text[digit] = 'z';
  std::ofstream(index) << text;
  try {
    load_block_index(path("p"));
    ADD_FAILURE() << "a bad occupancy grid was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "blocks[0].occupancy.bits") << e.what();
  }
}

#include "render/partition/partition.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "render/partition/occupancy_axis.hpp"
#include "render/scene/scene_stream.hpp"
#include "common/error.hpp"
#include "common/json_fields.hpp"
#include "common/output_folder.hpp"
#include "common/unfinished_output.hpp"

namespace rayline::partition {
namespace fs = std::filesystem;

// Sec. 6 / cell_walk.hpp: the occupancy grid a ray tests before it visits a cell.
void mark_occupancy(const Bounds& cell, const Bounds& tb, BlockInfo::Occupancy& bits) {
  constexpr int R = BlockInfo::kOccupancyRes;
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    const float ext = cell.hi[a] - cell.lo[a];
    if (!occupancy_axis_resolved(ext, R)) {  // flat, too thin or too wide: the whole axis
      lo[a] = 0, hi[a] = R - 1;
      continue;
    }
    const float inv = float(R) / ext;
    const float f0 = std::floor((tb.lo[a] - cell.lo[a]) * inv), f1 = std::floor((tb.hi[a] - cell.lo[a]) * inv);
    lo[a] = occupancy_voxel(f0 - 1.0f, R, 0);
    hi[a] = occupancy_voxel(f1 + 1.0f, R, R - 1);
  }
  for (int z = lo[2]; z <= hi[2]; ++z)
    for (int y = lo[1]; y <= hi[1]; ++y)
      for (int x = lo[0]; x <= hi[0]; ++x) {
        const int bit = x + R * (y + R * z);
        bits[std::size_t(bit / 64)] |= std::uint64_t(1) << (bit % 64);
      }
}

using scene::ImportStats;
using scene::TriangleBatchFn;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::uint64_t splitmix64(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

Float3 centroid(const Triangle& t) {
  return {(t.v0.x + t.v1.x + t.v2.x) * (1.0f / 3), (t.v0.y + t.v1.y + t.v2.y) * (1.0f / 3),
          (t.v0.z + t.v1.z + t.v2.z) * (1.0f / 3)};
}
Bounds tri_bounds(const Triangle& t) {
  Bounds b;
  b.lo = {std::min({t.v0.x, t.v1.x, t.v2.x}), std::min({t.v0.y, t.v1.y, t.v2.y}), std::min({t.v0.z, t.v1.z, t.v2.z})};
  b.hi = {std::max({t.v0.x, t.v1.x, t.v2.x}), std::max({t.v0.y, t.v1.y, t.v2.y}), std::max({t.v0.z, t.v1.z, t.v2.z})};
  return b;
}
bool finite(const Triangle& t) {
  for (const Float3* v : {&t.v0, &t.v1, &t.v2})
    if (!std::isfinite(v->x) || !std::isfinite(v->y) || !std::isfinite(v->z)) return false;
  return true;
}

// ---- kd-tree construction on the centroid sample --------------------------------------

struct TreeBuilder {
  std::vector<KdNode> nodes;
  std::uint32_t next_block = 0;

  std::uint32_t build(const Bounds& cell, Float3* begin, Float3* end, std::uint32_t k) {
    const auto id = static_cast<std::uint32_t>(nodes.size());
    nodes.push_back(KdNode{});
    nodes[id].cell = cell;
    if (k == 1) {
      nodes[id].block = next_block++;
      return id;
    }
    const std::size_t n = std::size_t(end - begin);
    // Axis of largest centroid spread inside this node (cell extent when the sample is
    // too small or degenerate), split at the floor(k/2)/k quantile.
    Bounds cb;
    for (Float3* p = begin; p != end; ++p) cb.extend(*p);
    const std::uint32_t kl = k / 2;
    int axis = 0;
    float split = 0;
    bool ok = false;
    if (n >= 2) {
      const Float3 e = cb.extent();
      axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
      if (e[axis] > 0) {
        const std::size_t idx = n * kl / k;
        std::nth_element(begin, begin + idx, end, [axis](const Float3& a, const Float3& b) { return a[axis] < b[axis]; });
        split = begin[idx][axis];
        // Keep the plane strictly inside the cell so both children have volume.
        ok = split > cell.lo[axis] && split < cell.hi[axis];
      }
    }
    if (!ok) {
      const Float3 e = cell.extent();
      axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
      split = cell.lo[axis] + e[axis] * (float(kl) / float(k));
      if (!(split >= cell.lo[axis] && split <= cell.hi[axis])) split = cell.lo[axis];
    }
    const std::size_t left_n =
        std::size_t(std::partition(begin, end, [axis, split](const Float3& a) { return a[axis] < split; }) - begin);
    Bounds lc = cell, rc = cell;
    lc.hi[axis] = split;
    rc.lo[axis] = split;
    nodes[id].axis = axis;
    nodes[id].split = split;
    const std::uint32_t l = build(lc, begin, begin + left_n, kl);
    const std::uint32_t r = build(rc, begin + left_n, end, k - kl);
    nodes[id].left = l;
    nodes[id].right = r;
    return id;
  }
};

// Leaves whose cell the AABB overlaps or comes within `eps` of (rule in partition.hpp).
template <class F>
void route(const std::vector<KdNode>& nodes, const Bounds& b, float eps, F&& leaf) {
  std::array<std::uint32_t, 128> stack;
  int sp = 0;
  stack[sp++] = 0;
  while (sp > 0) {
    const KdNode& n = nodes[stack[--sp]];
    if (n.leaf()) {
      leaf(n.block);
      continue;
    }
    const float lo = b.lo[n.axis], hi = b.hi[n.axis], s = n.split;
    if (hi >= s - eps) stack[sp++] = n.right;
    if (lo <= s + eps) stack[sp++] = n.left;
  }
}

// ---- block writers ----------------------------------------------------------------------

struct BlockWriter {
  std::string path;
  std::vector<unsigned char> buf;
  std::uint64_t triangles = 0;
  std::uint32_t crc = 0;
  Bounds geometry;
  Bounds cell;
  BlockInfo::Occupancy occupancy{};

  void flush() {
    if (buf.empty()) return;
    crc = crc32_update(crc, buf);
    const int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
    if (fd < 0) throw std::runtime_error(path + ": cannot open for appending");
    write_all(fd, buf.data(), buf.size());
    ::close(fd);
    buf.clear();
  }
  void write_all(int fd, const unsigned char* p, std::size_t n) const {
    while (n > 0) {
      const ssize_t w = ::write(fd, p, n);
      if (w < 0) {
        if (errno == EINTR) continue;
        ::close(fd);
        throw std::runtime_error(path + ": write failed (disk full?)");
      }
      p += w, n -= std::size_t(w);
    }
  }
};

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
  out.flush();
  if (!out) throw std::runtime_error(p.string() + ": write failed");
}

// Neighbours through the tree: for each leaf, the leaves touching its upper faces.
void find_neighbours(BlockIndex& idx) {
  const Float3 ext = idx.bounds.extent();
  std::vector<std::uint32_t> stack;
  for (const KdNode& leaf : idx.nodes) {
    if (!leaf.leaf()) continue;
    const Bounds& c = leaf.cell;
    for (int a = 0; a < 3; ++a) {
      if (c.hi[a] >= idx.bounds.hi[a]) continue;  // face on the scene boundary
      Bounds face = c;
      face.lo[a] = face.hi[a] = c.hi[a];
      stack.assign(1, 0);
      while (!stack.empty()) {
        const KdNode& n = idx.nodes[stack.back()];
        stack.pop_back();
        if (n.leaf()) {
          if (n.block == leaf.block || n.cell.lo[a] != c.hi[a]) continue;
          double area = 1;
          bool touching = true;
          for (int b = 0; b < 3; ++b) {
            if (b == a) continue;
            const double ov = double(std::min(c.hi[b], n.cell.hi[b])) - double(std::max(c.lo[b], n.cell.lo[b]));
            if (ov < 0 || (ov == 0 && ext[b] > 0)) touching = false;
            area *= std::max(ov, 0.0);
          }
          if (!touching) continue;
          idx.blocks[leaf.block].neighbours.push_back({n.block, a, area});
          idx.blocks[n.block].neighbours.push_back({leaf.block, a, area});
          continue;
        }
        if (face.lo[n.axis] <= n.split) stack.push_back(n.left);
        if (face.hi[n.axis] >= n.split) stack.push_back(n.right);
      }
    }
  }
  for (auto& b : idx.blocks)
    std::sort(b.neighbours.begin(), b.neighbours.end(),
              [](const Neighbour& x, const Neighbour& y) { return x.block < y.block; });
}

// An existing --out is replaced only when it holds nothing but an earlier partition's files
// (common/output_folder.hpp); a new one needs its parent folder.
const OwnFiles kPartitionFiles = {"blocks.json", "block_*.rlb"};

fs::path check_target(const std::string& out_dir, const std::string& flag) {
  const fs::path target = replaceable_folder(out_dir, flag, kPartitionFiles);
  std::error_code ec;
  if (!fs::exists(target, ec) && !fs::is_directory(target.parent_path(), ec))
    throw InputError(out_dir, flag, "parent folder " + target.parent_path().string() + " does not exist");
  return target;
}

}  // namespace

// ---- BlockIndex queries -----------------------------------------------------------------

std::uint32_t BlockIndex::locate(Float3 p) const {
  std::uint32_t i = 0;
  while (!nodes[i].leaf()) i = p[nodes[i].axis] < nodes[i].split ? nodes[i].left : nodes[i].right;
  return nodes[i].block;
}

std::vector<std::uint32_t> BlockIndex::cells_along_ray(Float3 o, Float3 d, float tmin, float tmax) const {
  std::vector<std::uint32_t> out;
  if (nodes.empty()) return out;
  // Clip to the root cell (slab test).
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < bounds.lo[a] || o[a] > bounds.hi[a]) return out;
      continue;
    }
    float t0 = (bounds.lo[a] - o[a]) / d[a], t1 = (bounds.hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    tmin = std::max(tmin, t0), tmax = std::min(tmax, t1);
  }
  if (!(tmin <= tmax)) return out;
  struct Item { std::uint32_t node; float t0, t1; };
  std::vector<Item> stack{{0, tmin, tmax}};
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    const KdNode& n = nodes[it.node];
    if (n.leaf()) {
      out.push_back(n.block);
      continue;
    }
    const float oa = o[n.axis], da = d[n.axis];
    const float entry = oa + da * it.t0;  // position along the axis where the interval starts
    const bool left_first = entry < n.split || (entry == n.split && da < 0);
    const std::uint32_t near = left_first ? n.left : n.right, far = left_first ? n.right : n.left;
    if (da == 0) {
      stack.push_back({near, it.t0, it.t1});
      continue;
    }
    const float t = (n.split - oa) / da;
    if (t >= it.t1 || t <= it.t0) {
      stack.push_back({near, it.t0, it.t1});  // the interval never crosses the plane
    } else {
      stack.push_back({far, t, it.t1});
      stack.push_back({near, it.t0, t});
    }
  }
  return out;
}

// ---- JSON -------------------------------------------------------------------------------

namespace {
using json = nlohmann::ordered_json;
json f3(Float3 v) { return json::array({v.x, v.y, v.z}); }
json bounds_json(const Bounds& b) {
  if (b.empty()) return nullptr;
  return json{{"lo", f3(b.lo)}, {"hi", f3(b.hi)}};
}
}  // namespace

std::string block_index_to_json(const BlockIndex& idx) {
  json j;
  j["format"] = "rayline-blocks";
  j["version"] = 1;
  j["scene"] = idx.scene;
  j["scene_triangles"] = idx.scene_triangles;
  j["references"] = idx.references;
  j["bounds"] = bounds_json(idx.bounds);
  j["block_file"] = {{"header_bytes", kBlockHeaderBytes}, {"record_bytes", kRecordBytes},
                     {"vertex_layout", "v0 v1 v2 float32 x9, material uint32, little-endian"},
                     {"checksum", "crc32 (zlib) of the payload"}};
  json nodes = json::array();
  for (const KdNode& n : idx.nodes) {
    if (n.leaf()) nodes.push_back({{"block", n.block}});
    else nodes.push_back({{"axis", n.axis}, {"split", n.split}, {"left", n.left}, {"right", n.right}});
  }
  j["kdtree"] = {{"root", 0},
                 {"rule", "inner: coordinate < split goes left; ray order: child on the origin's side first"},
                 {"nodes", nodes}};
  json blocks = json::array();
  for (const BlockInfo& b : idx.blocks) {
    json nb = json::array();
    for (const Neighbour& x : b.neighbours) nb.push_back({{"block", x.block}, {"axis", x.axis}, {"area", x.area}});
    blocks.push_back({{"id", b.id}, {"file", b.file}, {"triangles", b.triangles}, {"bytes", b.file_bytes},
                      {"payload_crc32", b.payload_crc32}, {"cell", bounds_json(b.cell)},
                      {"geometry_bounds", bounds_json(b.geometry)}, {"neighbours", nb}});
    if (b.has_occupancy) {
      char hex[17];
      std::string bits;
      for (std::uint64_t word : b.occupancy) {
        std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(word));
        bits += hex;
      }
      blocks.back()["occupancy"] = {{"resolution", BlockInfo::kOccupancyRes}, {"bits", bits}};
    }
  }
  j["blocks"] = blocks;
  return j.dump(1) + "\n";
}

namespace {

using Field = OrderedJsonField;

// A coordinate: a JSON number that a float holds (a larger one would become infinite).
float coordinate(const Field& f) {
  const double v = f.number();
  if (!(std::fabs(v) <= double(std::numeric_limits<float>::max()))) f.fail("must be a finite float");
  return static_cast<float>(v);
}

// {"lo": [x, y, z], "hi": [x, y, z]} with lo <= hi on every axis; null is the empty
// bounds where `may_be_empty` (the geometry of a block without triangles).
Bounds bounds_field(const Field& f, bool may_be_empty) {
  Bounds r;
  if (may_be_empty && f.json().is_null()) return r;
  f.object();
  for (const char* end : {"lo", "hi"}) {
    const Field v = f.at(end);
    if (v.array().size() != 3) v.fail("must be an array of 3 numbers");
  }
  for (int i = 0; i < 3; ++i) {
    r.lo[i] = coordinate(f.at("lo").element(std::size_t(i)));
    r.hi[i] = coordinate(f.at("hi").element(std::size_t(i)));
    if (r.lo[i] > r.hi[i]) f.fail("lo above hi on axis " + std::to_string(i));
  }
  return r;
}

std::uint32_t index_below(const Field& f, std::size_t n, const char* what) {
  if (n == 0 || !f.json().is_number_unsigned() || f.json().get<std::uint64_t>() >= n)
    f.fail(std::string("must be a ") + what + " index from 0 to " + std::to_string(n == 0 ? 0 : n - 1));
  return static_cast<std::uint32_t>(f.json().get<std::uint64_t>());
}

}  // namespace

BlockIndex load_block_index(const std::string& dir) {
  const std::string file = (fs::path(dir) / "blocks.json").string();
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file, "", "cannot open (not a partitioned scene folder?)");
  std::stringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(file, "", "cannot read");
  // Parsed with the depth limit of every JSON input (kMaxJsonDepth); every value is then
  // checked for its type and range before it is converted (converting 1e20 to an int is
  // undefined behaviour).
  const OrderedJsonInput input(file);
  const json doc = input.parse(text.str());
  const Field root = input.field(doc, "");
  root.object();
  if (root.at("format").string() != "rayline-blocks") root.fail_at("format", "not a block index");
  if (const Field v = root.at("version"); v.json() != 1) v.fail("unsupported version (this build reads version 1)");
  BlockIndex idx;
  idx.scene = root.at("scene").string();
  idx.scene_triangles = root.at("scene_triangles").unsigned_integer();
  idx.references = root.at("references").unsigned_integer();
  idx.bounds = bounds_field(root.at("bounds"), false);
  const std::vector<Field> blocks = root.at("blocks").elements();
  if (blocks.empty() || blocks.size() > (std::size_t(1) << 20))
    root.fail_at("blocks", "must list 1 to 1048576 blocks");
  const std::size_t nb = blocks.size();
  for (std::size_t i = 0; i < nb; ++i) {
    const Field& b = blocks[i];
    BlockInfo bi;
    if (b.at("id").integer(0, std::int64_t(nb) - 1) != std::int64_t(i)) b.at("id").fail("ids must be 0..N-1 in order");
    bi.id = static_cast<std::uint32_t>(i);
    bi.file = b.at("file").string();
    if (bi.file.empty() || bi.file == "." || bi.file == ".." ||
        bi.file.find_first_of(std::string("/\0", 2)) != std::string::npos)
      b.at("file").fail("must be a plain file name");
    bi.triangles = b.at("triangles").unsigned_integer();
    bi.file_bytes = b.at("bytes").unsigned_integer();
    bi.payload_crc32 = static_cast<std::uint32_t>(b.at("payload_crc32").integer(0, 0xffffffffll));
    bi.cell = bounds_field(b.at("cell"), false);
    bi.geometry = bounds_field(b.at("geometry_bounds"), true);
    if (const auto o = b.find("occupancy")) {
      if (const Field r = o->at("resolution"); r.json() != BlockInfo::kOccupancyRes)
        r.fail("must be " + std::to_string(BlockInfo::kOccupancyRes));
      const Field bits_field = o->at("bits");
      const std::string bits = bits_field.string();
      if (bits.size() != bi.occupancy.size() * 16 || bits.find_first_not_of("0123456789abcdef") != std::string::npos)
        bits_field.fail("must be " + std::to_string(bi.occupancy.size() * 16) + " lower-case hex digits");
      for (std::size_t k = 0; k < bi.occupancy.size(); ++k)
        bi.occupancy[k] = std::stoull(bits.substr(k * 16, 16), nullptr, 16);
      bi.has_occupancy = true;
    }
    for (const Field& n : b.at("neighbours").elements()) {
      Neighbour x;
      x.block = index_below(n.at("block"), nb, "block");
      x.axis = static_cast<int>(n.at("axis").integer(0, 2));
      x.area = n.at("area").number();
      bi.neighbours.push_back(x);
    }
    idx.blocks.push_back(std::move(bi));
  }
  // The kd-tree: node 0 the root, children after their parent, every node but the root
  // the child of exactly one node and every block the leaf of exactly one. Otherwise it
  // is no partition: a node's cell would depend on which parent came last, and a block
  // reached from no cell, or from two, would render wrong without a word.
  const Field nodes_field = root.at("kdtree").at("nodes");
  const std::vector<Field> nodes = nodes_field.elements();
  if (nodes.size() != 2 * nb - 1) nodes_field.fail("expected 2N-1 nodes for N blocks");
  std::vector<std::uint8_t> parents(nodes.size(), 0), leaves(nb, 0);
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const Field& n = nodes[i];
    KdNode k;
    if (n.has("block")) {
      k.block = index_below(n.at("block"), nb, "block");
      if (leaves[k.block]++) n.at("block").fail("block " + std::to_string(k.block) + " is the leaf of two nodes");
    } else {
      k.axis = static_cast<int>(n.at("axis").integer(0, 2));
      k.split = coordinate(n.at("split"));
      k.left = index_below(n.at("left"), nodes.size(), "node");
      k.right = index_below(n.at("right"), nodes.size(), "node");
      for (const std::uint32_t child : {k.left, k.right}) {
        if (child <= i) n.fail("a child must come after its parent");
        if (parents[child]++) n.fail("node " + std::to_string(child) + " has two parents");
      }
    }
    idx.nodes.push_back(k);
  }
  // 2N-1 nodes, each but the root with one parent: N-1 inner nodes and N leaves, so
  // every block has its leaf.
  // Inner cells from the root down (children always follow their parent).
  idx.nodes[0].cell = idx.bounds;
  for (KdNode& n : idx.nodes) {
    if (n.leaf()) continue;
    Bounds l = n.cell, r = n.cell;
    l.hi[n.axis] = n.split, r.lo[n.axis] = n.split;
    idx.nodes[n.left].cell = l, idx.nodes[n.right].cell = r;
  }
  return idx;
}

// ---- the partitioner ----------------------------------------------------------------------

PartitionResult partition_triangles(const TriangleSource& source, const std::string& name, const std::string& out_dir,
                                    const PartitionOptions& opt) {
  if (opt.blocks < 1 || opt.blocks > (1u << 20)) throw InputError(name, "--blocks", "must be in [1, 1048576]");
  if (opt.memory_limit < (std::uint64_t(16) << 20)) throw InputError(name, "--memory-limit", "must be at least 16MiB");
  const std::uint64_t min_buffer = 64 * kRecordBytes;
  const std::uint64_t buffer_budget = opt.memory_limit / 2;
  if (std::uint64_t(opt.blocks) * min_buffer > buffer_budget)
  {
    const std::string needs = std::to_string(opt.blocks) + " blocks (needs " +
                              std::to_string(2 * opt.blocks * min_buffer) + " bytes)";
    if (!opt.memory_limit_flag.empty()) throw InputError(name, opt.memory_limit_flag, "too small for " + needs);
    throw InputError(name, "--blocks", "too many: the partition's " + std::to_string(opt.memory_limit) +
                                           "-byte buffer bound holds at most " +
                                           std::to_string(buffer_budget / min_buffer) + " blocks, not " + needs);
  }
  std::uint64_t per_block = std::min<std::uint64_t>(buffer_budget / opt.blocks, std::uint64_t(1) << 20);
  per_block -= per_block % kRecordBytes;
  const std::uint64_t sample_cap =
      std::max<std::uint64_t>(1024, std::min<std::uint64_t>(opt.sample_limit, opt.memory_limit / 8 / sizeof(Float3)));

  const fs::path target = check_target(out_dir, opt.out_flag);

  PartitionResult res;
  res.buffer_bytes_per_block = per_block;
  BlockIndex& idx = res.index;
  idx.scene = name;

  // Pass 1: bounds, count, reservoir sample of centroids.
  auto t0 = Clock::now();
  std::vector<Float3> sample;
  sample.reserve(std::size_t(std::min<std::uint64_t>(sample_cap, 1 << 20)));
  std::uint64_t seen = 0;
  std::uint64_t rng = opt.seed;
  Bounds bounds;
  PartitionProgress prog{1, 0, 0};
  source([&](std::span<const Triangle> batch) {
    for (const Triangle& t : batch) {
      if (!finite(t))
        throw InputError(name, "triangles", "triangle #" + std::to_string(seen) + " has a non-finite vertex");
      bounds.extend(t.v0), bounds.extend(t.v1), bounds.extend(t.v2);
      const Float3 c = centroid(t);
      if (sample.size() < sample_cap) {
        sample.push_back(c);
      } else {
        const std::uint64_t j = splitmix64(rng) % (seen + 1);
        if (j < sample_cap) sample[std::size_t(j)] = c;
      }
      ++seen;
    }
    prog.triangles_done = seen;
    if (opt.progress) opt.progress(prog);
  });
  if (seen == 0) throw InputError(name, "meshes", "the scene has no triangles");
  // Cell extents, split planes and occupancy scales are differences of coordinates: they
  // must be finite floats (finite vertices up to ±3.4e38 can still span more).
  if (const Float3 e = bounds.extent(); !std::isfinite(e.x) || !std::isfinite(e.y) || !std::isfinite(e.z))
    throw InputError(name, "triangles", "the scene bounds span more than the float range along an axis "
                                        "(coordinates near ±3.4e38): scale the scene down");
  idx.scene_triangles = seen;
  idx.bounds = bounds;
  res.sample_size = sample.size();

  TreeBuilder tb;
  tb.nodes.reserve(2 * opt.blocks - 1);
  tb.build(bounds, sample.data(), sample.data() + sample.size(), opt.blocks);
  idx.nodes = std::move(tb.nodes);
  std::vector<Float3>().swap(sample);
  res.seconds_pass1 = seconds_since(t0);

  // Pass 2: route into per-block buffers, append to block files. A triangle within
  // route_eps of a split plane goes to both sides: a renderer's hit found at t a few ulps
  // past the plane (rounding of t versus the plane's t) is then still in the cell whose
  // interval holds it, so hits never fall between cells (render/integrator/cell_walk.hpp).
  const Float3 ext = bounds.extent();
  const float route_eps = 1e-5f * std::max({ext.x, ext.y, ext.z, std::fabs(bounds.lo.x), std::fabs(bounds.lo.y),
                                            std::fabs(bounds.lo.z), std::fabs(bounds.hi.x), std::fabs(bounds.hi.y),
                                            std::fabs(bounds.hi.z), 1e-30f});
  t0 = Clock::now();
  const fs::path partial = partial_folder(target.string());
  const unfinished::Guard unfinished_guard(partial.string());  // removed if the run is interrupted
  std::error_code ec;
  fs::remove_all(partial, ec);
  fs::create_directories(partial, ec);
  if (ec) throw InputError(out_dir, opt.out_flag, "cannot create " + partial.string() + ": " + ec.message());
  try {
    std::vector<BlockWriter> w(opt.blocks);
    const std::vector<unsigned char> placeholder(kBlockHeaderBytes, 0);
    for (std::uint32_t b = 0; b < opt.blocks; ++b) {
      char fname[32];
      std::snprintf(fname, sizeof fname, "block_%05u.rlb", b);
      w[b].path = (partial / fname).string();
      write_text(w[b].path, std::string(placeholder.begin(), placeholder.end()));
      w[b].buf.reserve(std::size_t(per_block));
      if (opt.progress && b % 256 == 255) {  // (a file costs system calls: many blocks take seconds)
        const PartitionProgress creating{2, 0, seen, b + 1, opt.blocks};
        opt.progress(creating);
      }
    }
    for (const KdNode& n : idx.nodes)
      if (n.leaf()) w[n.block].cell = n.cell;
    std::uint64_t routed = 0;
    prog = {2, 0, seen, opt.blocks, opt.blocks};
    source([&](std::span<const Triangle> batch) {
      for (const Triangle& t : batch) {
        const Bounds tb = tri_bounds(t);
        route(idx.nodes, tb, route_eps, [&](std::uint32_t leaf) {
          BlockWriter& bw = w[leaf];
          encode_records(std::span<const Triangle>(&t, 1), bw.buf);
          bw.geometry.extend(tb);
          mark_occupancy(bw.cell, tb, bw.occupancy);
          ++bw.triangles;
          if (bw.buf.size() + kRecordBytes > per_block) bw.flush();
        });
      }
      routed += batch.size();
      prog.triangles_done = routed;
      if (opt.progress) opt.progress(prog);
    });
    if (routed != seen)
      throw std::runtime_error("the scene delivered " + std::to_string(routed) + " triangles in pass 2 but " +
                               std::to_string(seen) + " in pass 1");
    idx.blocks.resize(opt.blocks);
    for (std::uint32_t b = 0; b < opt.blocks; ++b) {
      BlockWriter& bw = w[b];
      bw.flush();
      std::vector<unsigned char>().swap(bw.buf);
      BlockInfo& bi = idx.blocks[b];
      bi.id = b;
      bi.file = fs::path(bw.path).filename().string();
      bi.triangles = bw.triangles;
      bi.geometry = bw.geometry;
      bi.has_occupancy = true;  // an empty block: no voxel set
      bi.occupancy = bw.occupancy;
      bi.payload_crc32 = bw.crc;
      bi.file_bytes = kBlockHeaderBytes + bw.triangles * kRecordBytes;
      idx.references += bw.triangles;
    }
    for (const KdNode& n : idx.nodes)
      if (n.leaf()) idx.blocks[n.block].cell = n.cell;
    for (std::uint32_t b = 0; b < opt.blocks; ++b) {
      const BlockInfo& bi = idx.blocks[b];
      BlockHeader h;
      h.triangle_count = bi.triangles;
      h.block_id = b;
      h.block_count = opt.blocks;
      h.cell = bi.cell;
      h.geometry_bounds = bi.geometry;
      h.payload_bytes = bi.triangles * kRecordBytes;
      h.payload_crc32 = bi.payload_crc32;
      const auto hb = encode_block_header(h);
      if (opt.progress && b % 256 == 255) {
        const PartitionProgress finishing{3, seen, seen, b + 1, opt.blocks};
        opt.progress(finishing);
      }
      const int fd = ::open(w[b].path.c_str(), O_WRONLY | O_CLOEXEC);
      if (fd < 0 || ::pwrite(fd, hb.data(), hb.size(), 0) != ssize_t(hb.size())) {
        if (fd >= 0) ::close(fd);
        throw std::runtime_error(w[b].path + ": cannot write header");
      }
      ::close(fd);
    }
    find_neighbours(idx);
    write_text(partial / "blocks.json", block_index_to_json(idx));
    replaceable_folder(out_dir, opt.out_flag, kPartitionFiles);  // again: the user may have written there since
    publish_folder(partial.string(), target.string(), opt.out_flag);
  } catch (...) {
    fs::remove_all(partial, ec);
    throw;
  }
  res.dir = out_dir;
  res.seconds_pass2 = seconds_since(t0);
  return res;
}

PartitionResult partition_scene(const scene::Scene& scene, const std::string& out_dir, const PartitionOptions& opt) {
  return partition_triangles([&scene](const TriangleBatchFn& fn) { return scene::stream_scene(scene, fn); },
                             scene.source, out_dir, opt);
}

}  // namespace rayline::partition

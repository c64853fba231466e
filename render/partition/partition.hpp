// Streaming median-split kd-tree partitioner ("Blocks on disk"; paper Sec. 6).
//
// Splits a scene into N spatially coherent blocks of about equal triangle count, in
// bounded memory, in two streaming passes over the scene:
//   1. bounds, triangle count and a deterministic reservoir sample of triangle centroids
//      (at most `sample_limit` centroids, 12 bytes each);
//   2. the kd-tree is built on the sample: a node owning k leaves splits its cell at the
//      floor(k/2)/k quantile of its sample's centroids along the axis of largest centroid
//      spread (so any N works, not only powers of two); then every triangle is routed to
//      the leaf cells its axis-aligned bounding box overlaps, through per-block buffers
//      (together at most half of `memory_limit`, at most 1 MiB each: larger buffers only
//      cost page faults) appended to the block files.
// Cells tile the scene bounds and never overlap. A triangle is referenced by every cell
// its axis-aligned bounding box overlaps or comes within eps of, eps = 1e-5 of the scene's
// largest extent or coordinate (a conservative AABB test, not an exact triangle clip).
// Rule at a split plane s on axis a: left if lo[a] <= s + eps, right if hi[a] >= s - eps.
// The band makes rendering exact across partitions: a hit computed a few ulps beyond a
// plane is still found in the cell whose ray interval holds it.
//
// Output folder (written as DIR.partial.<pid>@<host>, then renamed to DIR):
//   block_00000.rlb … one block file per cell (format in block_file.hpp)
//   blocks.json        the always-resident top level (schema in block_index_to_json).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "render/partition/block_file.hpp"
#include "render/scene/mesh_sink.hpp"
#include "render/scene/scene.hpp"

namespace rayline::partition {

// One kd-tree node. Inner: axis in {0,1,2}, children left (coordinate < split) and right.
// Leaf: axis == -1 and `block` names the block. Node 0 is the root.
struct KdNode {
  int axis = -1;
  float split = 0;
  std::uint32_t left = 0, right = 0;
  std::uint32_t block = 0;
  Bounds cell;
  bool leaf() const { return axis < 0; }
};

// Two cells sharing part of a face: the face is perpendicular to `axis`, `area` is the
// shared surface area (0 only when the scene is flat along another axis).
struct Neighbour {
  std::uint32_t block = 0;
  int axis = 0;
  double area = 0;
};

struct BlockInfo {
  std::uint32_t id = 0;
  std::string file;            // relative to the block folder
  Bounds cell;                 // the kd-tree leaf cell
  Bounds geometry;             // bounds of its triangles (empty when it has none)
  std::uint64_t triangles = 0;
  std::uint64_t file_bytes = 0;  // header + payload
  std::uint32_t payload_crc32 = 0;
  std::vector<Neighbour> neighbours;  // sorted by block id
  // Empty-space skipping (cell_walk.hpp): the cell split into kOccupancyRes^3 voxels, bit
  // x + R·(y + R·z) set where a triangle's bounds, grown by one voxel, reach. A ray whose
  // segment in the cell meets no set voxel cannot hit anything there. Absent in older
  // block folders (has_occupancy false: every cell is visited).
  static constexpr int kOccupancyRes = 32;
  using Occupancy = std::array<std::uint64_t, kOccupancyRes * kOccupancyRes * kOccupancyRes / 64>;
  bool has_occupancy = false;
  Occupancy occupancy{};
};

// Sets the voxels of `cell` that the triangle bounds `tb`, grown by one voxel, reach.
void mark_occupancy(const Bounds& cell, const Bounds& tb, BlockInfo::Occupancy& bits);

struct BlockIndex {
  std::string scene;                  // scene source it was partitioned from
  std::uint64_t scene_triangles = 0;  // distinct triangles
  std::uint64_t references = 0;       // sum over blocks (>= scene_triangles: straddlers)
  Bounds bounds;                      // scene bounds = root cell
  std::vector<KdNode> nodes;
  std::vector<BlockInfo> blocks;

  // Leaf cell holding point p (p clamped into the root cell; ties go right).
  std::uint32_t locate(Float3 p) const;
  // Blocks whose cells the segment origin + t·dir, t in [tmin, tmax], passes through, in
  // front-to-back order (the ray order through cells: at each node the child on the
  // origin's side first).
  std::vector<std::uint32_t> cells_along_ray(Float3 origin, Float3 dir, float tmin, float tmax) const;
};

struct PartitionProgress {
  int pass = 1;                        // 1: bounds and sample, 2: routing and writing, 3: finishing files
  std::uint64_t triangles_done = 0;
  std::uint64_t triangles_total = 0;   // known in pass 2 only (0 in pass 1)
  std::uint32_t files_done = 0, files_total = 0;  // block files created (pass 2) or finished (pass 3)
};

struct PartitionOptions {
  std::uint32_t blocks = 64;
  std::uint64_t memory_limit = std::uint64_t(1) << 30;  // bound on sample + block buffers
  std::uint64_t sample_limit = std::uint64_t(1) << 22;   // centroids sampled at most
  std::uint64_t seed = 0x9e3779b97f4a7c15ull;            // reservoir sampling
  std::function<void(const PartitionProgress&)> progress;  // called once per batch
  // The flags that set out_dir and memory_limit, as messages name them. `rayline render`
  // sets "--blocks-dir" and "" (the bound is not its flag: too many --blocks is then the error).
  std::string out_flag = "--out";
  std::string memory_limit_flag = "--memory-limit";
};

struct PartitionResult {
  BlockIndex index;
  std::string dir;
  double seconds_pass1 = 0, seconds_pass2 = 0;
  std::uint64_t sample_size = 0;
  std::uint64_t buffer_bytes_per_block = 0;
};

// A scene source that can be streamed more than once, identically each time.
using TriangleSource = std::function<scene::ImportStats(const scene::TriangleBatchFn&)>;

// Partitions `source` into `out_dir`. `name` goes into blocks.json and error messages.
// Throws InputError on bad options, an empty scene, non-finite vertices or bounds whose
// extent overflows the float range, or an unusable output folder.
PartitionResult partition_triangles(const TriangleSource& source, const std::string& name,
                                    const std::string& out_dir, const PartitionOptions& opt);
PartitionResult partition_scene(const scene::Scene& scene, const std::string& out_dir, const PartitionOptions& opt);

// blocks.json text for an index (deterministic: no times, no absolute paths).
std::string block_index_to_json(const BlockIndex& index);
// Loads DIR/blocks.json; throws InputError(DIR/blocks.json, field, message).
BlockIndex load_block_index(const std::string& dir);

}  // namespace rayline::partition

// The BVH of one block for the GPU kernels (Sec. 6: "each block has its own BVH"), built on
// the CPU with Embree's BVH builder (rtcBuildBVH: binned SAH, Morton or spatial splits)
// and flattened into the layout shaders/traverse.comp reads (render/vulkan/README.md):
//   * Node (64 B): both children's boxes, so one node fetch tests two boxes
//     (Aila & Laine 2009). Per child: lo.xyz + child word, hi.xyz + triangle count.
//     Child word: an inner child's node index, or kLeafBit | first << 3 | count for a
//     leaf of `count` (<= 4) triangles starting at `first` in the triangle array.
//   * Tri (48 B): v0, v1, v2 exactly as stored in the block record, in leaf order;
//     the w slots carry the record index (prim) and the material as uint bits.
// The root (FlatBvh::root) is always an inner node. Boxes are widened by a few ulps so the
// box test never culls a box whose triangle the triangle test would hit.
// Also a CPU mirror of the kernels (the same operations in the same order) for tests.
// Embree stays out of this header.
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "render/vulkan/gpu_kernels.hpp"

namespace rayline::gpu::bvh {

inline constexpr std::uint32_t kLeafBit = 0x80000000u;
inline constexpr std::uint32_t kMaxLeafTriangles = 4;
inline constexpr int kStackSize = 64;  // traverse.comp's stack (must hold the tree depth)
inline constexpr int kMaxDepth = 48;   // Embree's maxDepth for the build

struct Child {
  float lo[3];
  std::uint32_t word;
  float hi[3];
  std::uint32_t count;  // triangles of a leaf child, 0 for an inner child
};
struct Node {
  Child c[2];
};
static_assert(sizeof(Node) == 64);

struct Tri {
  float v0[3];
  std::uint32_t prim;
  float v1[3];
  std::uint32_t material;
  float v2[3];
  std::uint32_t pad;
};
static_assert(sizeof(Tri) == 48);

inline std::uint32_t leaf_word(std::uint32_t first, std::uint32_t count) { return kLeafBit | first << 3 | count; }
inline bool is_leaf(std::uint32_t word) { return (word & kLeafBit) != 0; }
inline std::uint32_t leaf_first(std::uint32_t word) { return (word >> 3) & 0x0FFFFFFFu; }
inline std::uint32_t leaf_count(std::uint32_t word) { return word & 7u; }

struct FlatBvh {
  std::vector<Node> nodes;  // empty for an empty block
  std::vector<Tri> tris;
  std::uint32_t root = 0;   // index of the root node
  int depth = 0;            // inner-node levels (the traversal stack holds at most this many)
  double seconds = 0;       // whole build: primitives, Embree, flattening
  double embree_seconds = 0;
};

// The build's own arrays (Embree's build primitives, subtree heights), kept between builds
// together with a FlatBvh whose arrays are reused: fresh memory costs page faults, which
// on a loaded or virtualised host cost as much as the build (render/vulkan/README.md).
class BuildScratch {
 public:
  BuildScratch();
  ~BuildScratch();
  BuildScratch(const BuildScratch&) = delete;
  BuildScratch& operator=(const BuildScratch&) = delete;
  std::uint64_t bytes() const;
  struct Impl;
  std::unique_ptr<Impl> impl;
};

// Builds the BVH of `n` records (40 B each, block_file.hpp) into `out`, reusing its arrays
// and `scratch`. Triangles with a non-finite vertex are left out (never hit, as in
// Embree). Throws GpuError(Failed) when Embree fails and OutOfMemory for more than
// kMaxBlockTriangles.
void build(std::span<const unsigned char> records, std::uint64_t n, const GpuBuildOptions& opt, FlatBvh& out,
           BuildScratch& scratch);
FlatBvh build(std::span<const unsigned char> records, std::uint64_t n, const GpuBuildOptions& opt);
std::uint64_t capacity_bytes(const FlatBvh& b);

// CPU mirror of traverse.comp (tests and debugging): the same answers and doubt flags as
// intersect_closest / intersect_any (GpuHit, kAny* codes), up to fma fusion.
GpuHit closest(const FlatBvh& b, const GpuRay& r);
std::uint8_t any(const FlatBvh& b, const GpuRay& r);
// The kernels' triangle test alone: t where the ray meets `t` (ignoring [tmin, tmax]), or
// NaN on a miss. Brute force over every triangle with it checks that the box test never
// culls a hit.
float triangle_t(const Tri& t, const GpuRay& r);

}  // namespace rayline::gpu::bvh

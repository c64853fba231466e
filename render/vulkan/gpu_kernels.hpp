// The E-jobs of ray batching (Fig. 3, Sec. 3.1) as Vulkan compute dispatches on whole ray
// queues, and the data they need on the GPU: a scene block (its triangles + a BVH built
// on the CPU once on load) and a ray queue. Shading stays on the CPU (path_kernels.hpp):
// the closest-hit kernel returns the hit triangle's vertices and material, so the host
// never needs the block in RAM to shade a GPU hit.
#pragma once
#include <bit>
#include <cstdint>
#include <memory>
#include <span>

#include "render/vulkan/vulkan_device.hpp"

namespace rayline::gpu {

inline constexpr std::uint32_t kNoHit = 0xFFFFFFFFu;

// A ray as the kernels read it (32 B, std430): the query interval is [tmin, tmax].
struct GpuRay {
  float org[3];
  float tmin;
  float dir[3];
  float tmax;
};
static_assert(sizeof(GpuRay) == 32);

// Closest hit: the triangle with the smallest t in [tmin, tmax] (ties: the smaller prim);
// prim = kNoHit on a miss. `prim` is the triangle's index in the block file's records
// (the same id Embree reports for BlockGeometry), v = its vertices v0 v1 v2 as stored.
// (Added: on a miss t = +infinity, material = kNoHit and v is all zero.)
// Doubtful rays (render/vulkan/README.md): the kernel reports only what it decides exactly as
// Embree would; a ray where some candidate lies within a rounding margin of changing the
// answer (an edge, a near tie, the interval's ends) is flagged by the sign bit of t
// (rays need tmin >= 0, so an answer's t is never negative otherwise), and the rest of the
// hit is the kernel's own guess. Certain answers equal Embree's (same prim, same occlusion).
struct GpuHit {
  float t;
  std::uint32_t prim;
  std::uint32_t material;
  float v[9];
};
static_assert(sizeof(GpuHit) == 48);
inline bool doubtful(const GpuHit& h) { return (std::bit_cast<std::uint32_t>(h.t) >> 31) != 0; }
inline float hit_t(const GpuHit& h) { return std::bit_cast<float>(std::bit_cast<std::uint32_t>(h.t) & 0x7FFFFFFFu); }

// intersect_any's answer per ray: kAnyClear / kAnyOccluded when certain; doubtful rays get
// kAnyDoubtful, | kAnyOccluded when the kernel's own test found a hit.
inline constexpr std::uint8_t kAnyClear = 0, kAnyOccluded = 1, kAnyDoubtful = 2;

// A block resident in GPU memory (the RAM->GPU T-job makes it). Freed on destruction.
class GpuBlock {
 public:
  virtual ~GpuBlock() = default;
  virtual std::uint64_t triangles() const = 0;
  virtual std::uint64_t device_bytes() const = 0;
  double build_seconds = 0;   // CPU BVH build
  double upload_seconds = 0;  // host -> device copy
  // Added: the flattened BVH (render/vulkan/README.md): 64-byte BVH2 nodes, 48-byte triangles
  // in leaf order (more than triangles() only with GpuBvhQuality::High), tree depth.
  std::uint64_t bvh_nodes = 0;
  std::uint64_t leaf_triangles = 0;
  int bvh_depth = 0;
};

// `records`: a block file's payload (triangle_count records of 9 float32 + uint32 material,
// little-endian, block_file.hpp). Builds the BVH on the CPU, then uploads. Throws
// GpuError (OutOfMemory when the device cannot hold it).
std::unique_ptr<GpuBlock> upload_block(GpuContext& ctx, std::span<const unsigned char> records,
                                       std::uint64_t triangle_count);

// Added: how upload_block builds the BVH (Embree's BVH builder, rtcBuildBVH). Every quality
// gives the same hits; only build time and traversal speed differ.
enum class GpuBvhQuality : std::uint8_t {
  Low,     // Morton builder: fastest build, slowest traversal
  Medium,  // binned SAH (the default)
  High,    // SAH with spatial splits (a triangle may sit in several leaves): slowest build
};
struct GpuBuildOptions {
  GpuBvhQuality quality = GpuBvhQuality::Medium;
  int threads = 0;  // Embree build threads; 0 = every core
};
std::unique_ptr<GpuBlock> upload_block(GpuContext& ctx, std::span<const unsigned char> records,
                                       std::uint64_t triangle_count, const GpuBuildOptions& options);

// Added: the largest block upload_block takes on any device (the leaf word's 28-bit index);
// a device's own limit (maxStorageBufferRange / 48 B, 2.8 M triangles on lavapipe) may be
// lower and is reported as OutOfMemory.
inline constexpr std::uint64_t kMaxBlockTriangles = (std::uint64_t(1) << 28) - 1;

// A ray queue resident in GPU memory.
class GpuRays {
 public:
  virtual ~GpuRays() = default;
  virtual std::uint64_t size() const = 0;
  virtual std::uint64_t device_bytes() const = 0;
};
std::unique_ptr<GpuRays> upload_rays(GpuContext& ctx, std::span<const GpuRay> rays);

// RayIntersect's traversal: one hit per ray into `out` (out.size() == rays.size()).
// Returns the kernel's own time in seconds (GPU timestamps where the queue has them, else
// the host's wall time around submit + wait), not counting the download of `out`.
double intersect_closest(GpuContext& ctx, const GpuBlock& block, const GpuRays& rays, std::span<GpuHit> out);

// ShadowIntersect's traversal: out[i] = kAnyOccluded when some triangle certainly has t in
// [tmin, tmax], kAnyClear when certainly none has, else kAnyDoubtful (| kAnyOccluded if the
// kernel's own test found one).
double intersect_any(GpuContext& ctx, const GpuBlock& block, const GpuRays& rays, std::span<std::uint8_t> out);

// Added: where the time of one intersect call went (benchmarks, the renderer's metrics).
struct GpuDispatchStats {
  double kernel_seconds = 0;    // what intersect_* returns
  double submit_seconds = 0;    // host wall time from recording to the fence (kernel + copies)
  double copy_seconds = 0;      // GPU time of the device -> host copy (staging path, timestamps)
  double download_seconds = 0;  // host wall time copying the results into `out`
  std::uint64_t download_bytes = 0;
  bool gpu_timestamps = false;  // kernel_seconds from GPU timestamps (else host wall time)
  std::uint32_t dispatches = 0; // one per chunk of rays (a binding's maxStorageBufferRange)
};
double intersect_closest(GpuContext& ctx, const GpuBlock& block, const GpuRays& rays, std::span<GpuHit> out,
                         GpuDispatchStats* stats);
double intersect_any(GpuContext& ctx, const GpuBlock& block, const GpuRays& rays, std::span<std::uint8_t> out,
                     GpuDispatchStats* stats);

}  // namespace rayline::gpu

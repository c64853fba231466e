// The E-jobs of ray batching on one resident block (Fig. 3, Sec. 3.1), CPU version:
//   RayIntersect(SceneData_b, RayQueue_b): closest hit inside cell b; hits are shaded at
//     once (emission, next-event estimation → a shadow ray, a cosine-sampled continuation
//     with Russian roulette); misses continue to the next cell along the ray;
//   ShadowIntersect(SceneData_b, ShadowRayQueue_b): occlusion inside cell b; unoccluded
//     rays continue to the next cell, or add their radiance once past the last cell.
// Light transport conventions (the reference tracer in render/reference implements the
// same ones independently): two-sided Lambertian surfaces; material emission counted at
// every hit; area lights one-sided, invisible, sampled only by NEE (one light chosen
// uniformly, a point uniformly on it); constant environment for rays leaving the scene;
// max_depth = surface hits per path; Russian roulette from the 3rd hit with
// q = min(0.95, max(throughput)).
#pragma once
#include <cstdint>
#include <span>
#include <vector>

#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"
#include "render/trace/block_geometry.hpp"
#include "render/trace/film.hpp"
#include "render/trace/ray.hpp"

namespace rayline::trace {

struct TraceSettings {
  const scene::Scene* scene = nullptr;            // materials, lights, environment
  const partition::BlockIndex* cells = nullptr;   // the resident top level
  Film* film = nullptr;
  std::uint64_t seed = 1;
  int max_depth = 5;
  // Overlap of successive cell intervals in the Embree query, delta(t) = rel·t + abs (see
  // ray_interval in path_kernels.cpp). abs is set from the scene bounds by set_bounds().
  float overlap_rel = 1e-6f, overlap_abs = 0;
  // Empty-space skipping (cell_walk.hpp, segment_may_hit): a ray skips cells whose
  // occupancy grid its segment misses. The image is the same either way (tested).
  bool skip_empty = true;
  void set_bounds(const scene::Bounds& b);
};

// What happened to the rays of one job; sums over a frame give the conservation law
// created = ended (docs/architecture.md invariant).
struct RayCounts {
  std::uint64_t traced = 0;          // rays processed in a cell
  std::uint64_t created = 0;         // new rays (camera, continuation, shadow)
  std::uint64_t escaped = 0;         // path rays leaving the scene
  std::uint64_t terminated = 0;      // path rays ending at a hit (a continuation is a new ray)
  std::uint64_t occluded = 0;        // shadow rays blocked
  std::uint64_t unoccluded = 0;      // shadow rays reaching their light
  std::uint64_t paths_ended = 0;     // paths with no continuation (escaped, depth, roulette)
  std::uint64_t skipped = 0;         // cells a ray went past without a visit (empty space)
  std::uint64_t ended() const { return escaped + terminated + occluded + unoccluded; }
  RayCounts& operator+=(const RayCounts& o) {
    traced += o.traced, created += o.created, escaped += o.escaped, terminated += o.terminated;
    occluded += o.occluded, unoccluded += o.unoccluded;
    paths_ended += o.paths_ended;
    skipped += o.skipped;
    return *this;
  }
};

// A new ray placed in the cell where it starts (or ended at once: escaped / unoccluded,
// counted in `counts`, radiance added). Appends to `out` when it has a cell.
void place_new_ray(const TraceSettings& ts, RayRecord r, std::vector<RayRecord>& out, RayCounts& counts);

// Camera ray of (pixel, sample): counted in the film's sample count, then placed.
void generate_camera_ray(const TraceSettings& ts, scene::Float3 origin, scene::Float3 dir, std::uint32_t pixel,
                         std::uint32_t sample, std::vector<RayRecord>& out, RayCounts& counts);

void ray_intersect(const TraceSettings& ts, const BlockGeometry& block, std::span<const RayRecord> rays,
                   std::vector<RayRecord>& out, RayCounts& counts);

// ---- The pieces of RayIntersect / ShadowIntersect any traversal engine shares ----------
// (Embree here; the Vulkan kernels of render/gpu, which find hits on the GPU and leave the
// shading to these functions on the host.)

// The ray's query interval in its cell: (tnear, texit] widened by delta(t) on both sides
// (never before the ray's own start), clipped to the ray's tfar. Every engine tests the
// same interval, so every engine finds the same triangle.
void query_interval(const TraceSettings& ts, const RayRecord& r, float& tmin, float& tmax);

// The triangle a ray hit, as shading needs it.
struct HitTriangle {
  scene::Float3 v0, v1, v2;
  std::uint32_t material = 0;
};

// The canonical hit distance: t of the ray against the triangle's plane, computed in double
// precision from the stored vertices (Moller-Trumbore) and rounded once. Shading uses it
// instead of the engine's own t, so Embree and the GPU kernels (whose float arithmetic
// differs in the last bits) give bit-identical images whenever they pick the same
// triangle. `engine_t` is returned where the ray is parallel to the plane.
float canonical_hit_distance(const RayRecord& r, const HitTriangle& h, float engine_t);

// A path ray hit `h` in its cell: shade (emission, NEE shadow ray, continuation) into `out`.
void shade_hit(const TraceSettings& ts, const RayRecord& r, const HitTriangle& h, float engine_t,
               std::vector<RayRecord>& out, RayCounts& counts);

// No hit in the current cell (or an unoccluded shadow ray): continue in the next cell
// along the ray, or end (escape / reach the light).
void continue_ray(const TraceSettings& ts, const RayRecord& r, std::vector<RayRecord>& out, RayCounts& counts);
void shadow_intersect(const TraceSettings& ts, const BlockGeometry& block, std::span<const RayRecord> rays,
                      std::vector<RayRecord>& out, RayCounts& counts);
// The E-job of a queue of `kind` rays: ray_intersect or shadow_intersect.
void intersect(const TraceSettings& ts, const BlockGeometry& block, RayKind kind, std::span<const RayRecord> rays,
               std::vector<RayRecord>& out, RayCounts& counts);

// Ray origin offset along the normal (Wächter & Binder, Ray Tracing Gems ch. 6): a few
// ulps scaled by |p|, so self-intersection is avoided at any scene scale.
scene::Float3 offset_ray_origin(scene::Float3 p, scene::Float3 n);

}  // namespace rayline::trace

// The integrator of ray batching (Fig. 3, Sec. 3.1): what happens to a ray once the
// aggregate (render/accel/aggregate.hpp) has searched its cell, written once for every
// traversal engine:
//   after RayIntersect(SceneData_b, RayQueue_b): a closest hit inside cell b is shaded at
//     once (emission, next-event estimation -> a shadow ray, a cosine-sampled continuation
//     with Russian roulette); a miss continues to the next cell along the ray;
//   after ShadowIntersect(SceneData_b, ShadowRayQueue_b): an unoccluded ray continues to
//     the next cell, or adds its radiance once past the last cell.
// Light transport conventions (the reference tracer in render/reference implements the
// same ones independently): two-sided Lambertian surfaces; material emission counted at
// every hit; area lights one-sided, invisible, sampled only by NEE (one light chosen
// uniformly, a point uniformly on it); constant environment for rays leaving the scene;
// max_depth = surface hits per path; Russian roulette from the 3rd hit with
// q = min(0.95, max(throughput)).
#pragma once
#include <cstdint>
#include <vector>

#include "render/integrator/film.hpp"
#include "render/integrator/ray.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"

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
  // Rays a job makes in its own cell are traced in that job (accel::Aggregate::intersect),
  // not queued (RayBatchOptions::continue_in_cell). The image is the same either way.
  bool continue_in_cell = false;
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

// ---- The pieces of RayIntersect / ShadowIntersect every traversal engine shares ----------
// (Embree, render/embree; the Vulkan kernels, render/vulkan, which find hits on the GPU and
// leave the shading to these functions on the host.)

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

// After the closest-hit search of `r` in its cell (pbrt-v4's EnqueueWorkAfterIntersection
// / AfterMiss): `hit` the closest triangle (nullptr: none), `engine_t` its distance as the
// engine found it. A hit is shaded (emission, NEE shadow ray, continuation) into `out`; a
// miss continues in the next cell along the ray, or escapes. Counts the ray as traced.
void after_closest_hit(const TraceSettings& ts, const RayRecord& r, const HitTriangle* hit, float engine_t,
                       std::vector<RayRecord>& out, RayCounts& counts);

// After the occlusion test of shadow ray `r` in its cell: an occluded ray ends; an
// unoccluded one continues in the next cell, or reaches its light (radiance added).
// Counts the ray as traced.
void after_occlusion_test(const TraceSettings& ts, const RayRecord& r, bool occluded, std::vector<RayRecord>& out,
                          RayCounts& counts);

// Ray origin offset along the normal (Wächter & Binder, Ray Tracing Gems ch. 6): a few
// ulps scaled by |p|, so self-intersection is avoided at any scene scale.
scene::Float3 offset_ray_origin(scene::Float3 p, scene::Float3 n);

}  // namespace rayline::trace

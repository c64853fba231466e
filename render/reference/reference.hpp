// An in-core reference path tracer: the test oracle for the out-of-core ray-batching
// renderer (render/integrator, render/embree, render/engine). It shares no code with that renderer beyond the
// scene library: its own random numbers, its own traversal (one Embree 3 scene over every
// triangle), plain per-pixel iterative path tracing, no batching, no cells. The two must
// agree within Monte Carlo noise because both implement exactly these conventions:
//
//  * Camera (pinhole): pixel (x, y), y = 0 the TOP row, sample at (x+u, y+v), u, v ~ U[0,1).
//      forward = normalize(look_at − position), right = normalize(cross(forward, up)),
//      up' = cross(right, forward), t = tan(fov_y/2), aspect = width/height,
//      sx = (2(x+u)/width − 1)·t·aspect, sy = (1 − 2(y+v)/height)·t,
//      direction = normalize(forward + sx·right + sy·up').
//  * Surfaces: two-sided Lambertian, BRDF albedo/π, geometric normal flipped to face the
//    incoming ray. Material emission: radiance from both sides, added (× throughput) at
//    every surface hit, camera rays included.
//  * Area lights: parallelograms, one-sided (emit on the side of cross(edge_u, edge_v)),
//    never intersected and never occluding; reached only by next-event estimation: at every
//    hit one shadow ray to a point uniform on one light chosen uniformly,
//      pdf_area = 1 / (numLights · area),
//      contribution = T · albedo/π · Le · max(0, cos_surface) · max(0, cos_light) / (dist² · pdf_area)
//    when unoccluded. No MIS.
//  * Environment: constant radiance added (× throughput) when a ray hits nothing, at any
//    bounce (camera rays included). Shadow rays never see it.
//  * Depth: max_depth = the maximum number of surface hits on a path; emission and NEE at
//    each hit 1..max_depth; after hit d < max_depth a cosine-weighted continuation with
//    T *= albedo; then, for d >= 3, Russian roulette: survive with
//    q = min(0.95, max component of T), T /= q.
//
// Determinism: each camera sample draws from its own random stream keyed by (seed, pixel,
// sample), so an image depends on the seed only — never on the thread count or tile order.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "render/scene/scene.hpp"

namespace rayline::reference {

struct ReferenceOptions {
  int width = 0, height = 0;  // 0: the camera's resolution
  int spp = 0;                // 0: scene.render.spp
  int max_depth = -1;         // < 0: scene.render.max_depth (0 is allowed: environment only)
  std::uint64_t seed = 1;
  int threads = 0;            // 0: all hardware threads (TBB's default)
  int camera = 0;             // index into scene.cameras
};

struct ReferenceImage {
  int width = 0, height = 0, spp = 0, max_depth = 0;
  // Linear RGB radiance, mean over the spp samples; width·height·3 floats, top row first.
  std::vector<float> rgb;
  // Per pixel and channel: the unbiased sample variance s² = Σ(x − x̄)² / (spp − 1) of the
  // spp sample radiances (0 when spp == 1); same layout as rgb. The standard error of a
  // pixel's mean is sqrt(s² / spp).
  std::vector<float> variance;
  std::uint64_t triangles = 0;   // triangles in the Embree scene
  double build_seconds = 0;      // scene streaming + BVH build
  double trace_seconds = 0;

  std::size_t index(int x, int y, int channel) const {
    return (std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(channel);
  }
  // sqrt(variance / spp) of one pixel channel.
  double standard_error(int x, int y, int channel) const;
};

// Renders scene.cameras[opt.camera]. Throws InputError for bad options (non-positive size
// or spp, no such camera) and std::runtime_error when Embree fails.
ReferenceImage render_reference(const scene::Scene& scene, const ReferenceOptions& opt);

}  // namespace rayline::reference

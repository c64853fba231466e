// Scene profile (docs/architecture.md, "Workload"): what the simulator needs to know about a scene
// to make a path tracer's ray flow without tracing rays. Per data block (a kd-tree cell,
// Sec. 6 "median split into approximately even-sized data blocks"): its SceneData size,
// its cell bounds, its face neighbours with the shared surface area (the weights w_i of
// Sec. 5.2, Fig. 6), and the per-block statistics of the Markov fidelity level: hit ratio
// alpha, survival beta, shadow occlusion, and where missed rays go. Plus the image (Sec. 6
// Table 1: resolution, spp), the record sizes of the Fig. 3 data blocks, and a camera path
// (where primary rays enter the scene, per keyframe).
// File schema: docs/scene-profiles.md. Loader (JSON) in scene_profile_loader.cpp.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "sched/core/types.hpp"

namespace rayline {

struct ProfileNeighbour {
  int block = 0;      // index into SceneProfile::blocks
  double area = 0;    // shared surface area of the two cells (Sec. 5.2 weight w_i)
  double p = 0;       // Markov: P(next block = this | missed, not escaped); sums to 1
};

struct ProfileBlock {
  Bytes bytes = 0;                          // SceneData_b (geometry + acceleration structure)
  std::array<double, 3> lo{}, hi{};         // cell bounds
  std::vector<ProfileNeighbour> neighbours;
  double boundary_area = 0;                 // cell surface on the scene bounds (rays escape)
  // Markov statistics (fitted from traced paths; analytic ignores them).
  double alpha = 0;             // P(a ray in this cell hits geometry in it)
  double beta = 0;              // P(a path survives Russian roulette at a hit here)
  double escape = 0;            // P(a missed ray leaves the scene from this cell)
  double shadow_occlusion = 0;  // P(a shadow ray is occluded inside this cell)
  double shadow_exit = 0;       // P(an unoccluded shadow ray goes on to a neighbour cell)
};

// One camera keyframe: where the primary rays of a frame start (first cell entered).
struct CameraKey {
  std::vector<std::pair<int, double>> entry;  // (block, probability)
  double background = 0;                      // rays that miss every cell: escape at once
};

// The paper's own assumptions (Sec. 5.2): one alpha/beta for the whole scene, missed rays
// spread over the neighbours by shared surface area.
struct AnalyticParameters {
  double alpha = 0.6, beta = 0.5, shadow_occlusion = 0.3, shadow_exit = 0.5;
};

struct SceneProfile {
  std::string file;          // where it was loaded from (error messages)
  std::string name;
  std::string provenance;    // how the numbers were obtained (synthetic tracer, scaling)
  int width = 512, height = 512, spp = 4;
  int tiles_x = 4, tiles_y = 4;        // pixel accounting granularity (conservation)
  std::uint64_t wave_rays = 262144;    // primary rays per GenerateRays job
  std::uint64_t inflight_rays = 2000000;  // per client: new waves only while fewer rays alive
  int max_bounces = 5;                 // a path ends at this many bounces whatever beta says
  Bytes ray_bytes = 64, shadow_ray_bytes = 64, hit_bytes = 64;  // RayQueue, ShadowRayQueue, hit records
  Bytes sample_bytes = 16;             // one contribution record (Accumulate input)
  Bytes framebuffer_bytes_per_pixel = 16;
  Bytes request_bytes = 4096;          // an image request / wave descriptor (GenerateRays input)
  AnalyticParameters analytic;
  std::vector<ProfileBlock> blocks;
  std::vector<CameraKey> camera_path;

  int tiles() const { return tiles_x * tiles_y; }
  // Pixels of tile t (row-major tiles; edge tiles take the remainder).
  std::uint64_t tile_pixels(int t) const;
  Bytes scene_bytes() const;
};

// Loads and validates; throws InputError(file, field, message) on any problem: invalid
// JSON, unknown keys, block_count != number of blocks, negative or zero sizes, unknown or
// self neighbours, probabilities outside [0, 1] or not summing to one (1e-6), empty
// camera path, tiles that do not fit the image.
SceneProfile load_scene_profile(const std::string& path);
SceneProfile parse_scene_profile(const std::string& json_text, const std::string& file_label);

}  // namespace rayline

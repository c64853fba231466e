// The ray flow of one camera ray in expectation (docs/simulator.md "Throughput bounds"):
// what the path-tracing workload's ray-flow model (workload/path_trace_model.hpp) makes of
// a primary sample on average, computed in closed form instead of sampled.
//
// Per bounce k the rays entering the scene's cells form a row vector x_k over blocks
// (k = 0: the camera path's entry distribution, averaged over its keyframes, which the
// clients walk in turn). A ray that misses in cell b moves to neighbour b' with probability
// M[b][b'] (Intersect outcome "neighbour"), so the expected RayIntersect visits are
//     v_k = x_k (I - M)^-1,   hits h_k = v_k .* alpha,
// each hit is shaded where it happened and sends one shadow ray from there (next-event
// estimation), whose visits are u_k = h_k (I - S)^-1 with S the shadow chain's neighbour
// moves; survivors start bounce k + 1 in the same cell: x_{k+1} = h_k .* survive_k.
// Rays shot (the paper's unit, Sec. 6) = camera + secondary + shadow rays, each ends once.
#pragma once
#include <vector>

#include "workload/path_trace_model.hpp"
#include "workload/scene_profile.hpp"

namespace rayline {

struct RayFlowExpectation {
  // Per primary sample (one camera ray), per block: expected rays intersected there
  // (RayIntersect block visits), hit records shaded there, shadow rays intersected there.
  std::vector<double> intersect, shade, shadow;
  double camera = 1, secondary = 0, shadow_rays = 0;  // rays created per primary sample
  double rays_shot() const { return camera + secondary + shadow_rays; }
  double block_visits() const;  // sum of intersect and shadow visits: steady_block_visits' unit
};

// Analytic or Markov probabilities (replay uses Markov's, as its fallback does). Throws
// std::invalid_argument when a chain does not leave the scene (I - M singular).
RayFlowExpectation expected_ray_flow(const SceneProfile& profile, Fidelity fidelity);

}  // namespace rayline

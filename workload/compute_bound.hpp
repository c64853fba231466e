// The compute bound of path tracing on a platform (docs/simulator.md "Throughput bounds"):
// the most rays shot per second its compute devices could sustain if no ray ever waited
// for data, every job were large enough for its setup and its scene-block term (Eq. 2) to
// vanish, and work were split over the devices in the best proportions.
//
// With the expected ray flow per camera ray (workload/ray_flow_expectation.hpp), device d
// spends c(d, t) = bytes per record of t x T_RATE(d, t)[queue kind] seconds on one record
// of job type t (RayIntersect, Shade, ShadowIntersect; ray generation, accumulation and
// composition are left out, which only raises the bound). The bound is the linear program
//     maximise X  (camera rays per second)
//     s.t.  sum_d x(d, t, g) = X W(t, g)          for every job type t and block group g,
//           sum_{t, g} c(d, t) x(d, t, g) <= 1     for every compute device d,
//           x >= 0, and x(d, t, g) = 0 where d cannot run t or its memory cannot hold a
//           block of g (intersection jobs read the scene block on the device's memory),
// where W(t, g) is the expected work of type t on the blocks of group g per camera ray
// (blocks grouped by which devices can hold them). Identical devices are one variable
// block with capacity `count`. Solved with GLPK's simplex. Rays shot per second is X times
// rays shot per camera ray; no schedule of this platform and profile can exceed it.
#pragma once
#include <string>
#include <vector>

#include "sched/core/device_graph.hpp"
#include "workload/ray_flow_expectation.hpp"
#include "workload/scene_profile.hpp"

namespace rayline {

struct ComputeBound {
  double camera_rays_per_second = 0;
  double rays_shot_per_second = 0;       // the paper's unit
  double block_visits_per_second = 0;    // RayIntersect + ShadowIntersect visits
  // Per device kind (CPU, GPU): devices, the share of their time the optimum uses, and the
  // block visits they take at the optimum.
  struct Kind {
    std::string kind;
    int devices = 0;
    double busy_share = 0;
    double block_visits_per_second = 0;
  };
  std::vector<Kind> kinds;
  // Why the bound is zero, when it is (a block no device can intersect, no device for a
  // job type); empty otherwise.
  std::string limit;
};

ComputeBound compute_bound(const DeviceGraph& g, const SceneProfile& profile, const RayFlowExpectation& flow);

}  // namespace rayline

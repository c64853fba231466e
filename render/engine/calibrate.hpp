// `rayline calibrate`: measure this machine by rendering a scene under a memory
// budget that forces block loads, then fit the timing model (Sec. 3.2) by least squares:
//   Eq. 1 for the disk→RAM channel: T = LAT + bytes / BW x (1 + C x busy) over every
//     measured load (read with O_DIRECT + BVH build), busy the CPU threads' share while it
//     ran: the build shares the cores with them (C: the channel's cpu_contention);
//   the slowdown of the threads' jobs beside loads (the channel's exec_contention);
//   Eq. 2 per job type for a CPU hardware thread: T = SETUP + RATE·|rays| over the
//     measured RayIntersect / ShadowIntersect that ran beside no load (TimingModel::fit);
//   with a Vulkan device (--gpu): Eq. 2 for the GPU's jobs and Eq. 1 for the RAM->GPU
//     channel over every upload; when the mixed render gave the GPU too few jobs, a second
//     render with every GPU-capable job planned on the GPU measures it (calibrate.cpp).
// The result is a platform file the renderer reads with --platform.
#pragma once
#include <string>

#include "render/engine/renderer.hpp"
#include "render/engine/workstation.hpp"
#include "sched/core/fit_errors.hpp"

namespace rayline::engine {

struct CalibrationResult {
  WorkstationModel model;
  int load_samples = 0, exec_samples = 0;
  // How well each fit predicts its own samples (sched/core/fit_errors.hpp): Eq. 1 of the loads,
  // Eq. 2 per CPU thread of RayIntersect and ShadowIntersect.
  FitErrors load_fit, intersect_fit, shadow_fit;
  // The mean dispatch latency per CPU E-job (RenderResult::dispatch_gaps), and the control
  // loop's latency fitted to the gaps of threads that ran dry (model.loop; loop_fit, over
  // loop_samples gaps).
  Time dispatch_gap = 0;
  int loop_samples = 0, wake_samples = 0, pickup_samples = 0;
  int beside_load_samples = 0;
  int repeats = 1;                    // measuring renders made (per pass)
  int passes = 1;                     // measuring passes (calibrate())
  Time median_render_seconds = 0;     // the wall time of the one fitted  // CPU jobs that ran beside loads (Channel::exec_contention's fit)
  FitErrors loop_fit;
  // The GPU, when one was used: samples and whether each fit replaced the defaults.
  std::string gpu_device;
  int gpu_exec_samples = 0, pcie_samples = 0;
  bool gpu_intersect_fitted = false, gpu_shadow_fitted = false;
  std::string gpu_mixed_status;     // RenderResult::gpu_status of the mixed render
  int gpu_mixed_jobs[2] = {0, 0};  // GPU jobs of the mixed render: RayIntersect, ShadowIntersect
  bool gpu_pass = false;           // the GPU's own pass ran (the mixed one gave it too few jobs)
  FitErrors pcie_fit, gpu_intersect_fit, gpu_shadow_fit;
  std::string platform_json;
};

// Fits `c.model` to a render's own measurements (its other fields are kept): Eq. 1 of
// the disk->RAM channel over its loads (at least 2, else kept), Eq. 2 per job type of a
// CPU thread and of the GPU, the RAM->GPU channel, and the control loop's latency.
// calibrate() calls it on its render; `render --record-twin` on the
// recorded render (the twin's "recorded" timing, docs/validation.md).
void fit_model(const RenderResult& r, CalibrationResult& c);

// Fewer GPU jobs of a type than this in the mixed pass start the GPU's own pass (calibrate.cpp).
inline constexpr int kMinGpuJobsPerType = 32;

// Renders `opt` (its memory budget is set to `budget_fraction` of the scene's block bytes
// when opt.memory_budget is 0) and fits the model. Throws std::runtime_error when there
// are too few samples to fit.
// `min_gpu_jobs`: the GPU's own pass runs when the mixed render gave it fewer jobs of a type.
// `repeats`: measuring renders; the fit uses the one of median wall time.
// `passes`: 1 measures renders planned on the default platform; 2 (what a render that uses
// the file plans with) measures them once so, then `repeats` renders planned on that first
// fit, and fits those (docs/validation.md, "Calibrating in the regime of use").
CalibrationResult calibrate(RenderOptions opt, double budget_fraction = 0.3, int min_gpu_jobs = kMinGpuJobsPerType,
                            int repeats = 1, int passes = 1);

}  // namespace rayline::engine

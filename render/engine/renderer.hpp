// `rayline render` without the command line: scene → blocks on disk → the
// workstation's DCG → the same Scheduler objects the simulator uses → LocalExecutor →
// an image, metrics and a timeline. Tests call render() directly.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "render/engine/cluster.hpp"
#include "render/store/block_store.hpp"
#include "render/store/gpu_store.hpp"
#include "render/engine/render_workload.hpp"
#include "render/engine/workstation.hpp"
#include "render/integrator/path_kernels.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "sched/core/timing_model.hpp"

namespace rayline::partition {
struct PartitionProgress;
}

namespace rayline::engine {

struct RenderOptions {
  std::string scene;               // scene JSON or a bare mesh file; "" = the built-in scene
  std::string blocks_dir;          // a partition to use (made there when absent); "" = temporary
  std::uint32_t blocks = 0;        // cells when partitioning; 0 = chosen from scene size and budget
  std::string platform = "auto";   // "auto" or a platform file from `rayline calibrate`
  // A model in memory instead of the file (calibrate's fitted pass); `platform` names it.
  const WorkstationModel* model = nullptr;
  std::string scheduler = "gmb";   // gmb | gmb-ca | budge | loadanyonce
  int spp = 0, width = 0, height = 0, max_depth = 0;  // 0 = the scene's values
  Bytes memory_budget = 0;         // bytes of scene blocks in RAM; 0 = unlimited (in core)
  int threads = 0;                 // compute devices; 0 = hardware threads
  int build_threads = 0;           // threads of one BVH build (the disk->RAM channel); 0 = `threads`
  bool read_ahead = true;          // read the next planned block file during the current build
  bool skip_empty = true;          // rays go past cells whose occupancy grid they miss (cell_walk.hpp)
  int loaders = 0;                 // disk->RAM channels (loads at once); 0 = the platform's (auto: 1)
  std::uint64_t seed = 1;
  Time horizon = 2.0;              // k of GMB (Sec. 4.2)
  // Faults (docs/faults.md): "DEVICE@TIME" (a compute device of the workstation, e.g.
  // W.cpu1@0.5s: its thread finishes its job and starts nothing more), and the n-th block
  // read failing once (0: none).
  std::vector<std::string> faults;
  std::uint64_t fail_read = 0;
  Time aging = -1;                 // GMB (Sec. 4.3): <0 its default (5k, at least 1 s); kNever: off
  bool adaptive_aging = false;     // GMB: the threshold also at least twice the queue's median wait
  // BVH builder: "auto" = low (fast low-quality build) under a memory budget, where blocks are
  // rebuilt on every load, medium in core. The image does not depend on it.
  std::string bvh_quality = "auto";
  RenderWorkloadOptions batching;
  // Vulkan compute device: "none", "auto" (the first non-CPU-backed device, none
  // when there is no such device), an index, or a substring of the device name (an error
  // when it is not found). Its memory budget: 0 = half of the device's local memory.
  std::string gpu = "auto";
  Bytes gpu_memory_budget = 0;
  // Test hook (GpuContext::inject_fault): the n-th GPU operation fails with "oom" or "lost".
  int gpu_fault_after = 0;
  std::string gpu_fault = "lost";
  // Test hook: false answers the rays a GPU kernel flags doubtful with the kernel's own
  // guess instead of handing them to a CPU device (render/vulkan/README.md, "Doubtful rays"):
  // the image may then differ from the CPU-only one at edge cracks.
  bool gpu_resolve_doubtful = true;
  bool keep_schedule_outputs = true;  // timeline + jobs CSV in the result
  // A distributed render (render/mpi/README.md): one node per rank, this process rank 0.
  // `threads`, `memory_budget` and the GPU are per rank then (every rank opens the GPU rank
  // 0 opened, by name).
  Cluster* cluster = nullptr;
  // Calibration hook (calibrate.hpp): with a GPU, the plan lets the CPU threads run only
  // the doubtful rays' jobs, so every job the GPU can run is planned there (until the device
  // is lost: then the CPU threads take everything again). The image does not change.
  bool plan_gpu_only = false;
  // Called from the loop at most every 200 ms: fraction of paths done, rays/s so far.
  std::function<void(double fraction, double rays_per_second)> progress;
  // Passed to the partitioner when the scene is partitioned first (no --blocks-dir yet).
  std::function<void(const partition::PartitionProgress&)> partition_progress;
};

struct RenderResult {
  int width = 0, height = 0, spp = 0, max_depth = 0, threads = 0;
  int loaders = 1;  // disk->RAM channels of the platform driven
  std::uint64_t seed = 0;
  std::uint32_t blocks = 0;
  std::string scene_name, scheduler, scheduler_parameters, platform, bvh_quality;
  std::vector<float> rgb;                 // linear radiance, top row first
  std::vector<std::int64_t> sums;         // fixed-point film sums (bit-exact comparisons)
  std::vector<std::uint32_t> samples;     // camera samples per pixel
  trace::RayCounts counts;
  std::uint64_t camera_rays = 0, jobs = 0, merges = 0, film_dropped = 0;
  BlockStoreStats store;
  RunStats run;
  double seconds = 0;                     // wall time of the run (partitioning excluded)
  double partition_seconds = 0;
  double first_exec_start = 0;            // when the first E-job started (after the first load)
  // When the loop's first plan ran (RuntimeLoop::Trigger::planned_at): before it, the loop
  // made the first wave of camera rays (ControlLoop::per_camera_ray). -1: no plan.
  double first_plan_at = -1;
  std::uint64_t first_wave_camera_rays = 0;  // made before it (RayBatchWorkload::first_wave)
  Bytes scene_block_bytes = 0;            // sum of block footprints
  Bytes memory_budget = 0;
  std::uint32_t path_cap = 0;             // paths alive at once (lowered to fit the budget)
  std::uint32_t min_batch = 0, max_batch = 0;  // the batching settings used
  bool continue_in_cell = false, camera_jobs = false;
  std::vector<Bytes> block_bytes;         // each cell's block as the plan charges it
  std::string platform_json;              // the DCG driven, as a platform file (memory budget = RAM capacity)
  WorkstationModel workstation;           // ... and as its model
  Bytes rss_start_bytes = 0;              // process RSS when the run started (scene, index loaded)
  Bytes peak_rss_bytes = 0;               // process peak RSS at the end (getrusage)
  Bytes overhead_bound_bytes = 0;         // documented allowance beyond the budget
  std::string metrics_json, timeline_json, jobs_csv;
  // Measured activities, for `rayline calibrate` (Eq. 1 and Eq. 2 fits): every finished
  // E-job as a TimingSample (type 0: RayIntersect, 1: ShadowIntersect), every disk→RAM
  // T-job as a LoadSample (its BVH build shares the cores with the CPU threads' E-jobs).
  struct LoadSample {
    Bytes bytes = 0;
    Time seconds = 0;
    double busy = 0;  // the CPU threads' mean busy share (0..1) while it ran
  };
  std::vector<TimingSample> exec_samples;
  std::vector<double> exec_load_share;  // per exec sample: the mean number of loads running beside it
  std::vector<LoadSample> load_samples;
  // Per E-job on a CPU thread (the first on each excepted): how long the thread stood idle
  // after the job's inputs and the thread itself were ready, before the job started — the
  // loop's dispatch latency (events, planning, thread wake-up), which the plan does not see.
  std::vector<Time> dispatch_gaps;
  // E-jobs planned only after the thread's previous job had ended (the thread ran dry and
  // waited for the loop), in answer to a finished E-job: (that E-job's duration, the start
  // minus the later of the ready time above and that E-job's end). The control loop's
  // latency (DeviceGraph::loop) is fitted to them.
  std::vector<std::pair<Time, Time>> loop_samples;
  // Loads dispatched before the activity of another thread they waited for had ended: from
  // its end to their start (ControlLoop::wake, the loader thread woken on busy cores).
  std::vector<Time> wake_samples;
  // E-jobs dispatched before their thread's previous job ended, with their inputs in place
  // by then: from that end to their start (ControlLoop::pickup, the thread's hand-over).
  std::vector<Time> pickup_samples;
  // The GPU: the device used ("" when none), why none or what failed.
  std::string gpu_device, gpu_status = "none";
  int gpu_device_id = -1;                 // its compute device in the DCG (TimingSample::device)
  bool gpu_cpu_backed = false;
  bool gpu_resolve_doubtful = true;  // RenderOptions::gpu_resolve_doubtful (a test hook)
  Bytes gpu_memory_budget = 0;
  GpuStoreStats gpu;
  std::vector<std::pair<Bytes, Time>> pcie_samples;  // RAM->GPU T-jobs (bytes, seconds)
  // A distributed render: per rank, what it did; the LAN between the ranks as measured.
  std::vector<RankStats> ranks;
  LanModel lan;
  std::vector<std::pair<Bytes, Time>> lan_samples;  // rank-to-rank T-jobs (bytes, seconds)
};

// Throws InputError for bad input (scene, blocks, budget, platform, options).
RenderResult render(const RenderOptions& opt);

}  // namespace rayline::engine

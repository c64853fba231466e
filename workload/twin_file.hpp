// A render's twin file (`rayline render --record-twin NAME.twin.json`, read by `rayline
// simulate --like`; docs/validation.md): everything the simulator needs to run the same
// render — the platform the render drove (its DCG, with the memory budget as the host
// memory's capacity), the blocks' charged sizes, resolution, spp, path length, seed, the
// scheduler and the batching settings — beside the ray log (NAME.twin.rays) that holds
// every ray's outcome. The recording run's own measurements are kept for reference.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "sched/core/types.hpp"

namespace rayline {

struct TwinSpec {
  std::string scene;
  std::uint32_t width = 0, height = 0, spp = 0, max_depth = 0;
  std::uint64_t seed = 1;
  std::string scheduler = "gmb";
  double horizon = 2.0;
  std::uint32_t path_cap = 0, min_batch = 0, max_batch = 0;
  // Rays traced in their job's own cell (RayBatchOptions::continue_in_cell); twin files
  // without the key come from renders that queued every ray.
  bool continue_in_cell = false;
  bool camera_jobs = false;  // camera rays made by the jobs that trace them (RayBatchOptions)
  Bytes memory_budget = 0;          // 0: in core
  std::vector<Bytes> blocks;        // charged bytes of each cell's block
  std::string rays;                 // the ray log, relative to the twin file's folder
  std::string platform_json;        // the platform (DCG) the render drove
  // The same platform with Eq. 1, Eq. 2 and the control loop's latency fitted to the recording
  // run's own measurements ("" when none): timing known exactly, so a twin run on it
  // measures the workload model's error alone (docs/validation.md).
  std::string fitted_platform_json;
  // The recording render (slower than an unrecorded one: it keeps every job's input rays).
  double recorded_seconds = 0;
  std::uint64_t recorded_loads = 0, recorded_jobs = 0, recorded_traced = 0;

  // The ray log's path next to `twin_file`.
  std::string rays_path(const std::string& twin_file) const;
};

std::string twin_json(const TwinSpec& t);
// InputError naming the file and the field.
TwinSpec load_twin(const std::string& path);

}  // namespace rayline

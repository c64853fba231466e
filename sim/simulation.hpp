// One simulation run (issue 3): platform -> SimGrid, workload -> JobPool, scheduler ->
// Schedule, SimExecutor under the runtime loop; then metrics, jobs CSV and Chrome trace.
// Outputs go to OUT.partial.<pid>/ and are renamed to OUT/ only when complete.
#pragma once
#include <cstdint>
#include <string>

#include "sched/types.hpp"

namespace rayline::sim {

struct SimulationConfig {
  std::string platform_file;
  std::string workload = "ray-stream";  // "ray-stream" or a job-set JSON file
  std::string scheduler = "gmb";        // gmb | gmb-ca (completion-aware)
  Time horizon = 2.0;
  Time duration = 60.0;                 // simulated seconds (ray-stream); static sets run to the end
  std::uint64_t seed = 1;
  double exec_noise = 0.0;              // actual E-job time = predicted x U[1-n, 1+n]
  int blocks = 129;
  std::string out_dir = "out/simulate";
  bool paje = false;                    // SimGrid's own trace as OUT/simgrid.trace
  bool progress = false;                // a progress line on stderr
};

struct SimulationSummary {
  Time simulated = 0;
  double wall_seconds = 0;
  double scheduler_seconds = 0;
  double rays_per_second = 0;
  std::uint64_t activities = 0;
  bool stalled = false;        // queued jobs that no device could ever take
  std::size_t queued_at_end = 0;
};

SimulationSummary run_simulation(const SimulationConfig& cfg);

}  // namespace rayline::sim

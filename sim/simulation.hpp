// One simulation run: platform -> SimGrid, workload -> JobPool, scheduler ->
// Schedule, SimExecutor under the runtime loop; then metrics, jobs CSV and Chrome trace.
// Outputs go to OUT.partial.<pid>@<host>/ and are renamed to OUT/ only when complete; an existing
// OUT is replaced only when it holds nothing but a run's results (common/output_folder.hpp).
#pragma once
#include <cstdint>
#include <string>

#include "common/progress_line.hpp"
#include "sched/core/types.hpp"

namespace rayline::sim {

struct SimulationConfig {
  std::string platform_file;
  std::string workload = "ray-stream";  // "ray-stream", a job-set JSON file, or a scene profile (*.profile.json)
  std::string scheduler = "gmb";        // gmb | gmb-ca (completion-aware)
  Time horizon = 2.0;
  Time aging = -1;                      // GMB, Sec. 4.3: <0 its default (5k, at least 1 s); kNever: off
  bool adaptive_aging = false;          // GMB: also at least twice the queue's median wait
  Time duration = 60.0;                 // simulated seconds (ray-stream); static sets run to the end
  std::uint64_t seed = 1;
  double exec_noise = 0.0;              // actual E-job time = predicted x U[1-n, 1+n]
  // How T-jobs on channels that share a medium run (sim_executor.hpp, TransferOrder):
  // channel (at once, sharing it), resource (the plan's order on every resource) or
  // exclusive (one at a time, ready ones first).
  std::string transfer_order = "channel";
  int blocks = 129;
  std::string out_dir = "out/simulate";
  bool paje = false;                    // SimGrid's own trace as OUT/simgrid.trace
  bool timeline = true;                 // OUT/timeline.json (Chrome trace)
  ProgressLine::Mode progress = ProgressLine::Mode::Off;  // progress on stderr
  // Path-tracing workload (a scene profile; docs/scene-profiles.md).
  int clients = 1;
  int prediction_depth = 0;             // Sec. 5.2; 0: off
  bool merge_planned = true;            // path tracing: queues may join planned jobs
  bool retime_merged = true;            // path tracing: planned jobs that rays joined are re-timed
  bool cancel_failed = true;            // path tracing: withdraw failed predictions with their T-jobs
  std::string fidelity = "markov";      // analytic | markov | replay
  std::string replay_file;              // replay fidelity: the log to replay
  bool record_replay = false;           // write OUT/replay.log (every split of this run)
  Time warmup = -1;                     // steady state from here (<0: a third of the duration)
};

struct SimulationSummary {
  Time simulated = 0;
  double wall_seconds = 0;
  double scheduler_seconds = 0;
  double rays_per_second = 0;
  std::uint64_t activities = 0;
  bool stalled = false;        // queued jobs that no device could ever take
  std::size_t queued_at_end = 0;
  std::string stalled_reason;  // when stalled: which job, and why no device can take it (sched/policy/unplaced.hpp)
  // Path-tracing workload only.
  bool path_trace = false;
  double steady_rays_per_second = 0;    // rays intersected per second after the warm-up
  double prediction_accuracy = -1, prediction_ray_accuracy = -1;  // <0: prediction off
  std::uint64_t frames_delivered = 0;
  double busy = 0, setup = 0, fetching = 0, idle = 0;  // shares of compute-device time
};

SimulationSummary run_simulation(const SimulationConfig& cfg);

// Throws InputError(dir, flag, ...) unless `dir` may take a run's results: absent, empty,
// or holding only the files a run writes (metrics.json, jobs.csv, timeline.json,
// simgrid.trace, replay.log). `compare` and client sweeps check every run's folder first.
void check_results_folder(const std::string& dir, const std::string& flag);

}  // namespace rayline::sim

// One simulation run, in three steps: setup (platform -> SimGrid, workload -> JobPool,
// scheduler -> Schedule, SimExecutor under the runtime loop), run, and report (metrics,
// jobs CSV and Chrome trace).
// Outputs go to OUT.partial.<pid>@<host>/ and are renamed to OUT/ only when complete; an existing
// OUT is replaced only when it holds nothing but a run's results (common/output_folder.hpp).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/progress_line.hpp"
#include "sched/core/types.hpp"
#include "sched/policy/scheduler_factory.hpp"
#include "sim/sim_executor.hpp"
#include "workload/path_trace_model.hpp"

namespace rayline::sim {

// Where a run's jobs come from (the Workload seam, docs/architecture.md): the synthetic
// ray stream (runs for `duration`), a static job set (runs to its end), path tracing
// on a scene profile (Sec. 5-6, runs for `duration`), or the twin of a recorded render
// (`--like NAME.twin.json`, docs/validation.md: runs until its frame is done).
enum class WorkloadKind : std::uint8_t { RayStream, JobSet, PathTrace, Twin };

// A run, every option parsed (the command line checks them, apps/run/).
struct SimulationConfig {
  std::string platform_file;            // "" with a twin: the platform the render drove
  bool twin_fitted_timing = false;      // a twin on its recording's own fitted timing (--timing recorded)
  WorkloadKind workload_kind = WorkloadKind::RayStream;
  std::string workload = "ray-stream";  // as metrics.json names it: "ray-stream", or the file
  SchedulerChoice scheduler;
  Time duration = 60.0;                 // simulated seconds (ray stream, path tracing)
  std::uint64_t seed = 1;
  double exec_noise = 0.0;              // actual E-job time = predicted x U[1-n, 1+n], n in [0, 1)
  TransferOrder transfer_order = TransferOrder::Channel;  // T-jobs on channels that share a medium
  int blocks = 129;                     // scene blocks of the ray stream
  std::uint64_t host_memory = 0;        // >0: every host memory device's capacity (--memory-budget)
  std::string out_dir = "out/simulate";
  bool paje = false;                    // SimGrid's own trace as OUT/simgrid.trace
  bool timeline = true;                 // OUT/timeline.json (Chrome trace)
  ProgressLine::Mode progress = ProgressLine::Mode::Off;  // progress on stderr
  // Path-tracing workload (a scene profile; docs/scene-profiles.md).
  int clients = 1;
  int frames_in_flight = 1;             // frames each client keeps requested at once
  int frames_per_client = 0;            // >0: the run ends when each client has these (the makespan)
  int prediction_depth = 0;             // Sec. 5.2; 0: off
  bool merge_planned = true;            // queues may join planned jobs
  bool retime_merged = true;            // planned jobs that rays joined are re-timed
  bool cancel_failed = true;            // withdraw failed predictions with their T-jobs
  Fidelity fidelity = Fidelity::Markov;
  std::string replay_file;              // Fidelity::Replay: the log to replay
  bool record_replay = false;           // write OUT/replay.log (every split of this run)
  Time warmup = -1;                     // steady state from here (<0: a third of the duration)
  bool warm = false;                    // --start warm: memories begin holding the blocks used most
  // Faults to inject (docs/faults.md): "DEVICE@TIME" each, as --fail takes them.
  std::vector<std::string> faults;

  bool runs_for_duration() const {
    return workload_kind != WorkloadKind::JobSet && workload_kind != WorkloadKind::Twin;
  }
};

// A window is steady when the rays alive grew by at most this share of the rays shot in it
// (docs/simulator.md, "Steady state"); shrinking by more marks a backlog drained.
inline constexpr double kSteadyGrowth = 0.05;

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
  // Twin of a recorded render only: the simulated frame against the recording's.
  bool twin = false;
  std::uint64_t twin_loads = 0, twin_jobs = 0, recorded_loads = 0, recorded_jobs = 0;
  double recorded_seconds = 0;
  double steady_rays_per_second = 0;    // block visits (rays intersected in a block) per second after the warm-up
  double compute_bound_rays_shot_per_second = 0;  // path tracing: the most any schedule could reach (workload/compute_bound.hpp)
  double steady_rays_shot_per_second = 0;  // the paper's metric: rays traced to completion per second after the warm-up
  bool steady = true;             // the rays alive grew by at most 5 % of the rays shot in the window, or fill 90 % of the in-flight budgets
  double alive_growth_share = 0;  // (rays created - rays ended) / rays ended, in the window
  bool draining = false;          // the rays alive shrank by more than kSteadyGrowth of the rays shot: part of the rate is a backlog
  double prediction_accuracy = -1, prediction_ray_accuracy = -1;  // <0: prediction off
  std::uint64_t frames_delivered = 0;
  // Path tracing: the clients' framebuffers, pinned on one host memory device (its name and
  // capacity), against its capacity.
  std::string client_memory;
  double client_framebuffer_bytes = 0, client_memory_capacity = 0;
  std::string nothing_delivered;          // path tracing with no ray ended after the warm-up: why, what to change
  int faults_applied = 0;                 // --fail: faults that happened before the run ended
  std::uint64_t rays_lost = 0, frames_abandoned = 0;
  double busy = 0, setup = 0, fetching = 0, idle = 0;  // shares of compute-device time
};

SimulationSummary run_simulation(const SimulationConfig& cfg);

// Throws InputError(dir, flag, ...) unless `dir` may take a run's results: absent, empty,
// or holding only the files a run writes (metrics.json, jobs.csv, timeline.json,
// simgrid.trace, replay.log). `compare` and client sweeps check every run's folder first.
void check_results_folder(const std::string& dir, const std::string& flag);

}  // namespace rayline::sim

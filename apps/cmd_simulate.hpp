// `rayline simulate`: run a schedule on the SimGrid virtual platform.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace rayline::cli {

struct SimulateOptions {
  std::string platform;            // default: paper-cluster
  std::string workload = "ray-stream";
  std::string scheduler = "gmb";
  std::string horizon = "2s";
  std::string aging = "auto";      // GMB (Sec. 4.3): auto (5k, at least 1 s), adaptive, off, or a duration
  std::string rayline_off;         // Rayline's rules switched off, comma-separated (ablation)
  std::string rayline_on;          // Rayline's rules off by default switched on (generation)
  std::string steady = "loose";    // how a client sweep judges a point: loose, or strict (a backlog drained is not steady)
  int plan_cell = 32;              // GMB: nodes per plan cell (0: one cell; plan_cells.hpp)
  std::string duration = "60s";
  std::uint64_t seed = 1;
  double exec_noise = 0.0;
  std::string transfer_order = "channel";  // shared media at run time: channel, resource or exclusive
  int blocks = 129;
  std::string out = "out/simulate";
  bool paje = false;
  bool no_timeline = false;
  bool no_progress = false;
  // Path-tracing workload (--workload boeing|museum|FILE.profile.json).
  std::string clients = "1";        // N, or a list "1,2,4,8": one run per value, peak reported
  int prediction_depth = 0;
  std::string merge_planned = "on";
  std::string cancel_failed = "on";
  std::string retime_merged = "on";
  std::string fidelity = "markov";
  std::string replay;
  bool record_replay = false;
  std::string warmup;               // default: a third of --duration
  std::vector<std::string> fail;    // --fail DEVICE@TIME, repeatable (docs/faults.md)
  std::string start = "cold";       // --start cold|warm
  int frames_in_flight = 1;         // --frames-in-flight (path tracing)
  std::string memory_budget;        // --memory-budget: every node's host RAM (empty: the platform's)
  int frames = 0;                   // --frames: frames per client, then the run ends (0: until --duration)
  std::string like;                 // --like NAME.twin.json: the twin of a recorded render
  std::string timing = "platform";  // --timing platform|recorded (a twin's)
  bool scheduler_given = false;
  bool fidelity_given = false;      // --fidelity on the command line (a twin's default: replay)     // --scheduler on the command line (else a twin's own)
};
int run_simulate(const SimulateOptions& opt);
// One run, as run_simulate does it, writing its results folder at `dir` (inside compare's
// staging folder) while naming opt.out in what it prints. opt.clients is one count.
int run_simulate_into(const SimulateOptions& opt, const std::string& dir);
// A client sweep (opt.clients a list, or "auto") into dir/clients-N/; the peak's client
// count in `peak_clients`. Returns the sweep's exit code.
int run_sweep_into(const SimulateOptions& opt, const std::string& dir, int& peak_clients);
// Every flag run_simulate() parses and checks (platform and workload names, the scheduler,
// durations, the path-tracing options): InputError naming the flag, before anything runs
// (compare checks once for all its schedulers).
void check_simulate_flags(const SimulateOptions& opt);
// Before a run into `dir` (OUT, OUT/clients-N, compare's OUT/<scheduler>): InputError unless
// `dir` may be replaced and holds none of the run's input files.
void check_run_folder(const SimulateOptions& opt, const std::string& dir);
// Before runs that fill the folder of results folders `dir` (compare's OUT, a sweep's OUT),
// replaced as a whole: InputError unless it holds nothing but files matching `own` and
// folders matching `own_folders` that check_run_folder accepts, and none of the run's
// inputs. Returns the folder as replaceable_folder gives it.
std::string check_results_set(const SimulateOptions& opt, const std::string& dir, const std::vector<std::string>& own,
                              const std::vector<std::string>& own_folders);
// True when the run into `dir` completed: its results were published there (finished or
// stalled; a run that failed otherwise publishes nothing).
bool run_completed(const std::string& dir);

}  // namespace rayline::cli

// `rayline render` and `rayline calibrate`: the real out-of-core path tracer on
// this machine, planned by the same Scheduler objects as `rayline simulate`.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace rayline::cli {

struct RenderCliOptions {
  std::string scene;                 // scene JSON or bare mesh; empty: the built-in scene
  std::string blocks_dir;            // partition to use or create; empty: temporary
  std::uint32_t blocks = 0;          // 0: chosen from scene size and budget
  std::string platform = "auto";
  std::string scheduler = "gmb";
  int spp = 0, max_depth = 0, threads = 0;
  std::string resolution;            // "WxH"; empty: the scene camera's
  std::string memory_budget;         // "512MiB"; empty: unlimited (in core)
  std::uint64_t seed = 1;
  std::string horizon = "2s";      // --horizon DURATION (GMB, Sec. 4.2)
  std::vector<std::string> fail;  // --fail DEVICE@TIME (docs/faults.md)
  std::uint64_t fail_read = 0;    // --fail-read N
  std::string aging = "auto";        // --aging auto|adaptive|off|DURATION (GMB, Sec. 4.3)
  std::uint32_t paths = 0;           // paths in flight at most; 0 = auto
  std::string bvh_quality = "auto";
  std::string read_ahead = "on";     // --read-ahead on|off
  std::string skip_empty = "on";     // --skip-empty on|off
  std::string continue_in_cell = "on";  // --continue-in-cell on|off
  std::string camera_jobs = "on";       // --camera-jobs on|off
  int loaders = 0;                   // --loaders N (0 = the platform's)
  std::string gpu = "auto";          // none | auto | index | name
  std::string gpu_memory_budget;     // "4GiB"; empty: half of the device's memory
  std::string out = "out/render.exr";
  bool quiet = false;
  // per-cell ray statistics / a replay log from the renderer's kernels.
  std::string record_profile, record_replay;
  // NAME.twin.json (+ NAME.twin.rays): this render for `rayline simulate --like`.
  std::string record_twin;
  bool distributed = false;  // under mpirun (render/mpi)
  std::string record_tiles = "8x8";
  int record_keyframe = 0;
};
int run_render(const RenderCliOptions& opt);

struct CalibrateCliOptions {
  std::string scene;
  std::uint32_t blocks = 16;
  int threads = 0, spp = 4;
  std::string resolution = "256x256";
  double budget_fraction = 0.3;
  int repeats = 3;  // measuring renders; the fit takes the median one
  int passes = 2;   // the last pass's renders are planned on the pass before's fit
  std::string bvh_quality = "low";   // the builder whose loads are measured (a budget's default)
  std::string gpu = "auto";
  std::string out = "out/this-machine.json";
  bool quiet = false;
  bool distributed = false;  // under mpirun: the LAN between the ranks too (a cluster file)
};
int run_calibrate(const CalibrateCliOptions& opt);

}  // namespace rayline::cli

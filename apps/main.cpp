// The `rayline` command line. With cli_reference.cpp (the flag tables of docs/cli.md) the
// only translation unit that includes CLI11; every subcommand registers here, each option
// with its kind of value (cli_reference.hpp), and runs from its own cmd_*.cpp.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "apps/cli_common.hpp"
#include "apps/cli_reference.hpp"
#include "common/invocation.hpp"
#include "apps/huge_pages.hpp"
#include "apps/interrupt.hpp"
#include "apps/cmd_compare.hpp"
#include "apps/cmd_generate.hpp"
#include "apps/cmd_partition.hpp"
#include "apps/cmd_devices.hpp"
#include "apps/cmd_render.hpp"
#include "apps/cmd_report.hpp"
#include "apps/cmd_plan.hpp"
#include "apps/cmd_platform.hpp"
#include "apps/cmd_simulate.hpp"
#include "apps/version.hpp"
#include "sched/policy/scheduler_factory.hpp"

namespace {

using namespace rayline::cli;

// A seed is a plain decimal number that fits in 64 bits. CLI11 would take "-1" as
// 2^64 - 1 and clamp a longer number to it without a word; both are refused here.
const CLI::Validator kSeed(
    [](std::string& s) -> std::string {
      static const std::string kMax = "18446744073709551615";
      const bool digits = !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
      if (!digits || s.size() > kMax.size() || (s.size() == kMax.size() && s > kMax))
        return "'" + s + "' is not a seed: expected a whole number from 0 to " + kMax;
      return {};
    },
    "", "SEED");

// The factory's scheduler names (sched/policy/scheduler_factory.hpp), for CLI11's checks.
std::vector<std::string> scheduler_name_list() {
  return {std::begin(rayline::kSchedulerNames), std::end(rayline::kSchedulerNames)};
}

void add_platform(CLI::App& app, std::function<int()>& action) {
  auto* platform = app.add_subcommand("platform", "Inspect platform (device connectivity graph) files");
  platform->require_subcommand(1);
  auto opt = std::make_shared<PlatformCheckOptions>();
  auto* check = platform->add_subcommand(
      "check", "Validate a platform file and summarise it: nodes, devices, channels, shortest fetch times");
  check->add_option("file", opt->file, "Platform JSON file")->type_name(kPath)->required();
  check->add_option("--block-size", opt->block_size, "Block size for the fetch-time table")->type_name(kSize)
      ->default_val(opt->block_size);
  check->add_flag("--json", opt->json, "Print the summary as JSON");
  check->callback([opt, &action] { action = [opt] { return run_platform_check(*opt); }; });
}

void add_plan(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<PlanOptions>();
  auto* plan = app.add_subcommand("plan", "Plan a static job set (GMB by default) and report makespan and utilisation");
  plan->add_option("--platform", opt->platform, "Platform JSON (default: platforms/paper-cluster.json)")->type_name(kPath);
  plan->add_option("--jobs", opt->jobs, "Job-set JSON (default: a synthetic ray-batching job set)")->type_name(kPath);
  plan->add_option("--scheduler", opt->scheduler, "gmb (the paper), gmb-ca (completion-aware), loadanyonce (Navratil 2014), budge (Budge 2009) or rayline (Rayline's own, docs/rayline-policy.md)")->default_val(opt->scheduler);
  plan->add_option("--horizon,-k", opt->horizon, "Execution time threshold k (Sec. 4.2)")->type_name(kDuration)->default_val(opt->horizon);
  plan->add_option("--aging", opt->aging, "GMB aging threshold (Sec. 4.3): auto (5k, at least 1 s), adaptive, off, or a duration")->type_name(kAging)->default_val(opt->aging);
  plan->add_option("--trace", opt->trace, "Write timelines as Chrome trace JSON (open in Perfetto)")->type_name(kPath);
  plan->add_option("--jobs-csv", opt->jobs_csv, "Write per-job CSV")->type_name(kPath);
  plan->add_option("--synthetic-blocks", opt->synthetic_blocks, "Scene blocks of the synthetic job set")
      ->default_val(opt->synthetic_blocks)->check(CLI::Range(1, 1000000));
  plan->add_option("--synthetic-jobs", opt->synthetic_jobs, "Jobs of the synthetic job set")
      ->default_val(opt->synthetic_jobs)->check(CLI::Range(1, 100000000));
  plan->add_option("--seed", opt->seed, "Seed of the synthetic job set")->default_val(opt->seed)->check(kSeed);
  plan->add_flag("--quiet,-q", opt->quiet, "Print only the summary lines, no per-device table");
  plan->callback([opt, &action] { action = [opt] { return run_plan(*opt); }; });
}

void add_report(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<ReportOptions>();
  auto* r = app.add_subcommand(
      "report", "Write a self-contained HTML page (inline SVG charts) of a simulate, compare or render output folder");
  r->add_option("run_dir", opt->dir,
                "RUN_DIR: a folder written by `simulate --out`, `compare --out`, or holding a render's "
                "IMAGE.metrics.json (with IMAGE.jobs.csv, IMAGE.png)")
      ->required();
  r->add_option("--out,-o", opt->out, "HTML file to write (default: RUN_DIR/report.html)");
  r->callback([opt, &action] { action = [opt] { return run_report(*opt); }; });
}

#ifdef RAYLINE_WITH_SIM  // simulate, compare: need sim/ (SimGrid)
void add_simulate(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<SimulateOptions>();
  auto* sim = app.add_subcommand("simulate", "Run a schedule on the SimGrid virtual platform and measure it");
  sim->add_option("--platform", opt->platform, "Platform JSON or built-in name (default: paper-cluster)")->type_name(kPath);
  sim->add_option("--workload", opt->workload, "'ray-stream', a job-set JSON file, or path tracing on a scene profile: boeing, museum or FILE.profile.json")->default_val(opt->workload);
  sim->add_option("--scheduler", opt->scheduler, "gmb (the paper), gmb-ca (completion-aware), loadanyonce (Navratil 2014), budge (Budge 2009) or rayline (Rayline's own, docs/rayline-policy.md)")->default_val(opt->scheduler);
  sim->add_option("--horizon,-k", opt->horizon, "Execution time threshold k (Sec. 4.2)")->type_name(kDuration)->default_val(opt->horizon);
  sim->add_option("--aging", opt->aging, "GMB: a job that waited this long jumps the queue, oldest first (Sec. 4.3): auto (5k, at least 1 s), adaptive (auto, and at least twice the median wait of the queue), off, or a duration")->type_name(kAging)->default_val(opt->aging);
  sim->add_option("--rayline-off", opt->rayline_off, "Rayline's rules to switch off, comma-separated, for an ablation: ownership, image-split, completion, batching, no-waiting, job-size, room, generation, hold (docs/rayline-policy.md)")->type_name("RULES");
  sim->add_option("--rayline-on", opt->rayline_on, "Rayline's rules that are off by default to switch on: generation (rule 8, camera rays made by the owners of the blocks they enter), hold (rule 4 holds every small ray job while its node runs something; on with rule 8); docs/rayline-policy.md")->type_name("RULES");
  sim->add_option("--steady", opt->steady, "How a client sweep judges its points: loose counts a run whose rays alive shrank (a backlog of rays made before the window traced: frames longer than the run) as steady, strict does not (docs/simulator.md, \"Steady state\")")
      ->default_val(opt->steady)
      ->check(CLI::IsMember({"loose", "strict"}));
  sim->add_option("--plan-cell", opt->plan_cell, "GMB on large clusters: plan in cells of at most this many nodes (racks split, never joined); each device considers the jobs homed in its cell, and a cluster-level pass moves jobs to cells that run dry (docs/scheduler.md, \"Plan cells\"). 0: one cell, the paper's flat GMB at any size")->default_val(opt->plan_cell)->check(CLI::NonNegativeNumber);
  sim->add_option("--duration", opt->duration, "Simulated time for the ray stream")->type_name(kDuration)->default_val(opt->duration);
  sim->add_option("--seed", opt->seed, "Workload seed")->default_val(opt->seed)->check(kSeed);
  sim->add_option("--exec-noise", opt->exec_noise, "Actual E-job time = predicted x U[1-n,1+n]")->default_val(opt->exec_noise);
  sim->add_option("--transfer-order", opt->transfer_order,
                  "T-jobs on channels that share a medium (a NIC, a half-duplex SATA link): channel = each channel "
                  "in plan order, several at once sharing the medium; resource = the plan's order on every "
                  "resource (no contention: reality = plan); exclusive = one at a time per resource, a ready "
                  "T-job first")
      ->default_val(opt->transfer_order)
      ->check(CLI::IsMember({"channel", "resource", "exclusive"}));
  sim->add_option("--blocks,-n", opt->blocks, "Scene blocks of the ray stream")->default_val(opt->blocks)->check(CLI::Range(1, 1000000));
  sim->add_option("--out,-o", opt->out, "Output folder (metrics.json, jobs.csv, timeline.json); an existing one is replaced only if it holds nothing else")->type_name(kFolder)->default_val(opt->out);
  sim->add_flag("--paje", opt->paje, "Also write SimGrid's Paje trace (simgrid.trace)");
  sim->add_flag("--no-timeline", opt->no_timeline,
                "Skip timeline.json (the Chrome trace; ~250 B per activity, so ~0.25 GB for a long path-tracing run)");
  sim->add_flag("--quiet,-q,--no-progress", opt->no_progress, "No progress line on stderr");
  sim->add_option("--clients", opt->clients,
                  "Path tracing: clients requesting frames: N; N1,N2,... for a sweep reporting the peak; or auto, a "
                  "sweep doubling the clients until two counts in a row gain no more than 2 % or the rays alive keep "
                  "growing (the paper's peak: the best steady point); auto:M measures at most M clients")
      ->default_val(opt->clients);
  sim->add_option("--frames-in-flight", opt->frames_in_flight,
                  "Path tracing: frames each client keeps requested at once (the offered load; the paper's clients "
                  "feed requests frame by frame)")
      ->default_val(opt->frames_in_flight)
      ->check(CLI::Range(1, 64));
  sim->add_option("--memory-budget", opt->memory_budget,
                  "Host RAM of every node (each host memory device) for scene blocks and ray queues, e.g. 2GiB, as "
                  "render's --memory-budget (default: the platform file's capacities)")
      ->type_name("SIZE");
  sim->add_option("--frames", opt->frames,
                  "Path tracing: frames each client renders, then the run ends when the last is delivered (its "
                  "makespan); --duration caps it. 0 = frame after frame until --duration")
      ->default_val(opt->frames)
      ->check(CLI::Range(0, 1000000));
  sim->add_option("--prediction-depth", opt->prediction_depth, "Path tracing: job prediction depth (Sec. 5.2; 0 = off)")->default_val(opt->prediction_depth)->check(CLI::Range(0, 16));
  sim->add_option("--merge-planned", opt->merge_planned,
                  "Path tracing: on = arriving rays may join a planned, not yet started job (its E-job grows, see "
                  "--retime-merged); off = only unplanned queued jobs take them (Sec. 5.1)")
      ->default_val(opt->merge_planned)
      ->check(CLI::IsMember({"on", "off"}));
  sim->add_option("--retime-merged", opt->retime_merged,
                  "Path tracing with --merge-planned on: on = the planned E-job that rays joined is re-timed for its "
                  "grown queue, so the plan stays true; off = it runs longer than planned")
      ->default_val(opt->retime_merged)
      ->check(CLI::IsMember({"on", "off"}));
  sim->add_option("--cancel-failed", opt->cancel_failed,
                  "Path tracing with prediction: on = a planned predicted job that gets no rays is withdrawn with its "
                  "T-jobs (Sec. 5.2); off = it runs empty and its prefetches still move data")
      ->default_val(opt->cancel_failed)
      ->check(CLI::IsMember({"on", "off"}));
  sim->add_option("--fidelity", opt->fidelity, "Path tracing: ray-flow model analytic, markov or replay")->default_val(opt->fidelity);
  sim->add_option("--replay", opt->replay, "Path tracing: replay log for --fidelity replay")->type_name(kPath);
  sim->add_flag("--record-replay", opt->record_replay, "Path tracing: also write OUT/replay.log (this run's ray outcomes)");
  sim->add_option("--warmup", opt->warmup, "Path tracing: steady state starts here (default: a third of --duration)")->type_name(kDuration);
  sim->add_option("--start", opt->start,
                  "cold = scene blocks start on the disks only; warm = RAM and GPU memories start holding the blocks "
                  "used most (3/4 of each, the rest for rays), as after a long steady run (docs/simulator.md)")
      ->default_val(opt->start)
      ->check(CLI::IsMember({"cold", "warm"}));
  sim->add_option("--like", opt->like,
                  "Simulate a recorded render (NAME.twin.json from `rayline render --record-twin`): its platform, "
                  "blocks, settings, batching and scheduler, every ray's outcome from its ray log; runs until the "
                  "frame is done (docs/validation.md). --platform, --scheduler and --memory-budget override the recorded ones")
      ->type_name(kPath);
  sim->add_option("--timing", opt->timing,
                  "With --like: platform = the timing of the platform the render drove (a prediction, e.g. from "
                  "`rayline calibrate`); recorded = Eq. 1, Eq. 2 and the control loop's latency fitted to the recorded run itself "
                  "(the workload model's error alone)")
      ->default_val(opt->timing)
      ->check(CLI::IsMember({"platform", "recorded"}));
  sim->add_option("--fail", opt->fail,
                  "DEVICE@TIME: a node, memory or compute device fails at TIME (e.g. B3@10s); its work is re-planned "
                  "on the devices left, lost data made again where the workload can (repeatable; docs/faults.md)")->type_name(kFault);
  sim->callback([opt, sim, &action] {
    opt->scheduler_given = sim->count("--scheduler") > 0;
    opt->fidelity_given = sim->count("--fidelity") > 0;
    action = [opt] {
      use_huge_pages_for_large_allocations();  // apps/huge_pages.hpp
      return run_simulate(*opt);
    };
  });
}

void add_compare(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<CompareOptions>();
  SimulateOptions& o = opt->sim;
  auto* c = app.add_subcommand("compare", "Simulate the same platform and workload under several schedulers and compare them");
  c->add_option("--schedulers", opt->schedulers, "Comma-separated: gmb, gmb-ca, budge, loadanyonce, rayline")->default_val(opt->schedulers);
  c->add_option("--platform", o.platform, "Platform JSON or built-in name (default: paper-cluster)")->type_name(kPath);
  c->add_option("--workload", o.workload, "'ray-stream', a job-set JSON file, or boeing, museum, FILE.profile.json")->default_val(o.workload);
  c->add_option("--horizon,-k", o.horizon, "GMB horizon k (Sec. 4.2)")->type_name(kDuration)->default_val(o.horizon);
  c->add_option("--aging", o.aging, "GMB aging threshold (Sec. 4.3): auto (5k, at least 1 s), adaptive, off, or a duration")->type_name(kAging)->default_val(o.aging);
  c->add_option("--plan-cell", o.plan_cell, "GMB: nodes per plan cell, 0 for one cell (see simulate --help)")->default_val(o.plan_cell)->check(CLI::NonNegativeNumber);
  c->add_option("--duration", o.duration, "Simulated time")->type_name(kDuration)->default_val(o.duration);
  c->add_option("--transfer-order", o.transfer_order, "T-jobs on shared media: channel, resource or exclusive (see simulate --help)")
      ->default_val(o.transfer_order)
      ->check(CLI::IsMember({"channel", "resource", "exclusive"}));
  c->add_option("--seed", o.seed, "Workload seed")->default_val(o.seed)->check(kSeed);
  c->add_option("--clients", o.clients,
                "Path tracing: clients requesting frames: N; N1,N2,... or auto (auto:M: at most M clients) to sweep "
                "each scheduler and compare them at their own peaks (OUT/<scheduler>/clients-N/)")
      ->default_val(o.clients);
  c->add_option("--prediction-depth", o.prediction_depth, "Path tracing: job prediction depth (GMB only)")->default_val(o.prediction_depth)->check(CLI::Range(0, 16));
  c->add_option("--fidelity", o.fidelity, "Path tracing: analytic, markov or replay")->default_val(o.fidelity);
  c->add_option("--replay", o.replay, "Path tracing: replay log for --fidelity replay")->type_name(kPath);
  c->add_option("--warmup", o.warmup, "Path tracing: steady state starts here (default: a third of --duration)")->type_name(kDuration);
  c->add_option("--memory-budget", o.memory_budget, "Host RAM of every node, e.g. 2GiB (default: the platform file's)")
      ->type_name("SIZE");
  c->add_option("--frames-in-flight", o.frames_in_flight, "Path tracing: frames each client keeps requested at once")
      ->default_val(o.frames_in_flight)
      ->check(CLI::Range(1, 64));
  c->add_option("--start", o.start, "cold = scene blocks on the disks only; warm = memories start holding the blocks used most")
      ->default_val(o.start)
      ->check(CLI::IsMember({"cold", "warm"}));
  c->add_option("--out,-o", opt->out, "Output folder: OUT/<scheduler>/ per run (replaced only if it holds nothing but a run's files), OUT/compare.csv, compare.json")->type_name(kFolder)->default_val(opt->out);
  c->callback([opt, &action] {
    action = [opt] {
      use_huge_pages_for_large_allocations();  // apps/huge_pages.hpp
      return run_compare(*opt);
    };
  });
}
#endif  // RAYLINE_WITH_SIM

#ifdef RAYLINE_WITH_RENDER  // generate, partition, render, calibrate, devices: need render/
void add_generate(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<GenerateOptions>();
  auto* gen = app.add_subcommand(
      "generate", "Write a procedural scene (binary PLY + companion scene JSON), deterministic per seed");
  gen->add_option("name", opt->name, "Generator: museum-like, boeing-like, cornell, furnace, block-crossing");
  gen->add_option("--triangles", opt->triangles,
                  "Triangle count, K/M/G suffixes allowed, at most 4G (default: per generator). About 4M triangles/s: "
                  "large counts run for minutes, with a progress line on stderr (none with -q). The PLY holds at "
                  "most 2^31 vertices (block-crossing: 3 per triangle)")->type_name(kCount);
  gen->add_option("--out,-o", opt->out, "Mesh output path (.ply)")->type_name(kPath);
  gen->add_option("--seed", opt->seed, "Random seed")->default_val(opt->seed)->check(kSeed);
  gen->add_option("--scene-out", opt->scene_out, "Companion scene JSON (default: OUT with .json; '-': none)")->type_name(kPath);
  gen->add_flag("--list", opt->list, "List the generators and exit");
  gen->add_flag("--quiet,-q", opt->quiet, "No progress line on stderr; print only the timing line");
  gen->callback([opt, &action] { action = [opt] { return run_generate(*opt); }; });
}

void add_partition(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<PartitionOptions>();
  auto* part = app.add_subcommand(
      "partition", "Split a scene into N spatially coherent blocks on disk (streaming median-split kd-tree)");
  part->add_option("--scene", opt->scene, "Scene JSON or bare mesh file (default: the built-in scene)")->type_name(kPath);
  part->add_option("--blocks,-n", opt->blocks, "Number of blocks")->default_val(opt->blocks)->check(CLI::Range(1, 1 << 20));
  part->add_option("--out,-o", opt->out, "Output folder (replaced atomically, and only if it holds nothing but an earlier partition)")->type_name(kFolder)->default_val(opt->out);
  part->add_option("--memory-limit", opt->memory_limit, "Bound on the sample and block buffers")->type_name(kSize)
      ->default_val(opt->memory_limit);
  part->add_flag("--quiet,-q", opt->quiet, "No progress line on stderr; print only the timing line");
  part->callback([opt, &action] { action = [opt] { return run_partition(*opt); }; });
}

void add_render(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<RenderCliOptions>();
  auto* r = app.add_subcommand("render", "Render a scene out of core: blocks on disk, a RAM budget, GMB-planned loads and ray jobs");
  r->add_option("--scene", opt->scene, "Scene JSON or bare mesh file (default: the built-in Cornell-like room)")->type_name(kPath);
  r->add_option("--blocks-dir", opt->blocks_dir,
                "Partition folder to use (from `rayline partition`), or to create (default: a temporary one)")->type_name(kFolder);
  r->add_option("--blocks,-n", opt->blocks, "Blocks when partitioning (default: from scene size and budget)")
      ->check(CLI::Range(1, 1 << 20));
  r->add_option("--platform", opt->platform, "auto, or a platform file written by `rayline calibrate`")->type_name(kPath)
      ->default_val(opt->platform);
  r->add_option("--scheduler", opt->scheduler, "gmb | gmb-ca | budge | loadanyonce | rayline")
      ->default_val(opt->scheduler)
      ->check(CLI::IsMember(scheduler_name_list()));
  r->add_option("--spp", opt->spp, "Samples per pixel (default: the scene's)")->check(CLI::Range(1, 1 << 20));
  r->add_option("--max-depth", opt->max_depth, "Surface hits per path (default: the scene's)")->check(CLI::Range(1, 1000));
  r->add_option("--resolution", opt->resolution, "WIDTHxHEIGHT (default: the scene camera's)")->type_name(kResolution);
  r->add_option("--memory-budget", opt->memory_budget, "RAM for scene blocks and ray queues, e.g. 512MiB (default: unlimited)")->type_name(kSize);
  r->add_option("--threads,-j", opt->threads, "Worker threads = compute devices (default: all hardware threads)")
      ->check(CLI::Range(1, 4096));
  r->add_option("--seed", opt->seed, "Random seed (same seed: same image, bit for bit)")->default_val(opt->seed)->check(kSeed);
  r->add_option("--horizon,-k", opt->horizon, "GMB horizon k (Sec. 4.2), > 0")->type_name(kDuration)->default_val(opt->horizon);
  r->add_option("--fail", opt->fail,
                "DEVICE@TIME: a compute device (e.g. W.cpu1@0.5s) is lost at TIME: its thread finishes its job, "
                "the work planned there is re-planned on the others (repeatable; docs/faults.md)")->type_name(kFault);
  r->add_option("--fail-read", opt->fail_read,
                "N: the N-th block read fails once, as an I/O error would; the load is planned again (docs/faults.md)")
      ->default_val(opt->fail_read);
  r->add_option("--aging", opt->aging, "GMB aging threshold (Sec. 4.3): auto (5k, at least 1 s), adaptive, off, or a duration")->type_name(kAging)->default_val(opt->aging);
  r->add_option("--paths", opt->paths,
                "Paths in flight at most (bounds ray memory); 0 = auto: under --memory-budget all that fit next to "
                "the largest block, else 131072")
      ->default_val(opt->paths)
      ->check(CLI::Range(0, 1 << 26));
  r->add_option("--bvh-quality", opt->bvh_quality,
                "auto (low under a budget or at 4+ triangles per camera ray, else medium) | low (fast low-quality build) | medium | high; the image is the same")
      ->default_val(opt->bvh_quality)
      ->check(CLI::IsMember({"auto", "low", "medium", "high"}));
  r->add_option("--read-ahead", opt->read_ahead,
                "on = the next planned block file is read while the disk->RAM channel still builds the previous "
                "block's BVH (one staged file outside the budget); off = read and build in turn")
      ->default_val(opt->read_ahead)
      ->check(CLI::IsMember({"on", "off"}));
  r->add_option("--skip-empty", opt->skip_empty,
                "on = a ray goes past a cell whose occupancy grid (blocks.json) its segment misses, without a "
                "visit or a load (not with a single block: nothing to skip to); off = every cell along the ray is "
                "visited; the image is the same")
      ->default_val(opt->skip_empty)
      ->check(CLI::IsMember({"on", "off"}));
  r->add_option("--continue-in-cell", opt->continue_in_cell,
                "on = the rays a CPU job makes in its own cell (shadow rays, continuations) are traced in that "
                "job; off = every ray waits in its cell's queue for a job of its own; the image is the same")
      ->default_val(opt->continue_in_cell)
      ->check(CLI::IsMember({"on", "off"}));
  r->add_option("--camera-jobs", opt->camera_jobs,
                "on = with a scene of one block and CPU threads only, each job makes the camera rays it traces "
                "(no camera ray waits in a queue); off = camera rays are made on the loop's thread and queued; "
                "the image is the same")
      ->default_val(opt->camera_jobs)
      ->check(CLI::IsMember({"on", "off"}));
  r->add_option("--loaders", opt->loaders,
                "disk->RAM channels: block loads (read + BVH build) in flight at once; 0 = the platform's "
                "(one with --platform auto)")
      ->default_val(opt->loaders)
      ->check(CLI::Range(0, 16));
  r->add_option("--gpu", opt->gpu,
                "Vulkan device: none | auto (first non-CPU device, else none) | index | name substring (see `rayline devices`)")
      ->default_val(opt->gpu);
  r->add_option("--gpu-memory-budget", opt->gpu_memory_budget,
                "GPU memory for scene blocks and ray queues, e.g. 4GiB (default: half of the device's)")->type_name(kSize);
  r->add_option("--record-profile", opt->record_profile,
                "Write per-cell ray statistics of this render (JSON, docs/scene-profiles.md); CPU kernels only")->type_name(kPath);
  r->add_option("--record-replay", opt->record_replay,
                "Write a replay log of this render for `rayline simulate --fidelity replay` (CPU kernels only)")->type_name(kPath);
  r->add_option("--record-twin", opt->record_twin,
                "Write NAME.twin.json and NAME.twin.rays: this render's settings, platform and every ray's outcome, for "
                "`rayline simulate --like NAME.twin.json` (docs/validation.md); CPU kernels only")
      ->type_name(kPath);
  r->add_option("--record-tiles", opt->record_tiles, "Tile grid of the recorded replay log, TXxTY (the profile's image.tiles)")->type_name(kTiles)
      ->default_val(opt->record_tiles);
  r->add_option("--record-keyframe", opt->record_keyframe,
                "Camera keyframe this render stands for (replay log: frame and keyframe)")
      ->default_val(opt->record_keyframe)
      ->check(CLI::Range(0, 65535));
  r->add_option("--out,-o", opt->out, "Image, in the format its extension names: NAME.exr (OpenEXR, and a PNG preview NAME.png next to it) or "
                "NAME.png (8-bit sRGB); NAME.metrics.json, NAME.timeline.json, NAME.jobs.csv go next to it")->type_name(kPath)
      ->default_val(opt->out);
  r->add_flag("--distributed", opt->distributed,
             "Under mpirun: one node per rank (its threads, RAM under --memory-budget, disk), ranks joined by a "
             "measured LAN; rank 0 plans and writes the outputs (README, \"Render on several machines\")");
  r->add_flag("--quiet,-q", opt->quiet, "No progress line on stderr and no summary");
  r->callback([opt, &action] { action = [opt] { return run_render(*opt); }; });
}

void add_calibrate(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<CalibrateCliOptions>();
  auto* c = app.add_subcommand("calibrate", "Measure this machine (disk channel, per-thread job times), fit the timing model, write a platform file");
  c->add_option("--scene", opt->scene, "Scene to measure with (default: the built-in scene)")->type_name(kPath);
  c->add_option("--blocks,-n", opt->blocks, "Blocks to partition it into")->default_val(opt->blocks)->check(CLI::Range(2, 1 << 20));
  c->add_option("--threads,-j", opt->threads, "Worker threads (default: all hardware threads)")->check(CLI::Range(1, 4096));
  c->add_option("--spp", opt->spp, "Samples per pixel of the measuring render")->default_val(opt->spp)->check(CLI::Range(1, 1 << 16));
  c->add_option("--resolution", opt->resolution, "Resolution of the measuring render, WIDTHxHEIGHT")->type_name(kResolution)->default_val(opt->resolution);
  c->add_option("--budget-fraction", opt->budget_fraction, "RAM budget as a share of the scene's block bytes (forces loads)")
      ->default_val(opt->budget_fraction);
  c->add_option("--repeats", opt->repeats,
                "Measuring renders; the fit uses the one of median wall time (a machine shared with other work "
                "runs slow for a while now and then)")
      ->default_val(opt->repeats)
      ->check(CLI::Range(1, 100));
  c->add_option("--passes", opt->passes,
                "Measuring passes: the first renders are planned on default timings; with 2, one such render, then "
                "--repeats renders planned on its fit (as the renders that use the file are), and those are fitted")
      ->default_val(opt->passes)
      ->check(CLI::Range(1, 2));
  c->add_option("--bvh-quality", opt->bvh_quality,
                "BVH builder of the measured loads: low (what renders under a budget use), medium (in core), high; "
                "a load's time is mostly its build, so calibrate with the builder your renders use")
      ->default_val(opt->bvh_quality)
      ->check(CLI::IsMember({"low", "medium", "high"}));
  c->add_option("--gpu", opt->gpu, "Vulkan device to measure too: none | auto | index | name substring")
      ->default_val(opt->gpu);
  c->add_option("--out,-o", opt->out, "Platform file to write")->type_name(kPath)->default_val(opt->out);
  c->add_flag("--distributed", opt->distributed,
              "Under mpirun: also measure the LAN between every pair of ranks (ping-pong) and write a cluster "
              "platform file, one node per rank, for render --distributed and simulate");
  c->add_flag("--quiet,-q", opt->quiet, "No progress line on stderr");
  c->callback([opt, &action] { action = [opt] { return run_calibrate(*opt); }; });
}

void add_devices(CLI::App& app, std::function<int()>& action) {
  auto opt = std::make_shared<DevicesCliOptions>();
  auto* d = app.add_subcommand("devices", "List the Vulkan devices and the compute/memory devices, channels and timing model the renderer would use");
  d->add_option("--platform", opt->platform, "auto, or a platform file written by `rayline calibrate`")->type_name(kPath)->default_val(opt->platform);
  d->add_option("--threads,-j", opt->threads, "CPU compute devices (default: all hardware threads)")->check(CLI::Range(1, 4096));
  d->add_option("--gpu", opt->gpu, "none | auto | index | name substring")->default_val(opt->gpu);
  d->add_option("--memory-budget", opt->memory_budget, "RAM capacity to show (default: this machine's RAM)")->type_name(kSize);
  d->add_option("--gpu-memory-budget", opt->gpu_memory_budget, "GPU memory capacity (default: half of the device's)")->type_name(kSize);
  d->add_flag("--json", opt->json, "Print JSON instead of text");
  d->callback([opt, &action] { action = [opt] { return run_devices(*opt); }; });
}
#endif  // RAYLINE_WITH_RENDER

// Edit distance, for "did you mean" (names are a few letters long).
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string subcommand_names(const CLI::App& app) {
  std::string names;
  for (const CLI::App* sub : app.get_subcommands(std::function<bool(const CLI::App*)>{}))
    names += (names.empty() ? "" : ", ") + sub->get_name();
  return names;
}

// "platform check: " for the command path "rayline platform check"; "" for "rayline".
std::string where(const std::string& path) {
  const std::size_t space = path.find(' ');
  return space == std::string::npos ? std::string() : path.substr(space + 1) + ": ";
}

// The subcommand CLI11 stopped in (`app` itself when none), and its path ("rayline render").
const CLI::App* parsed_command(const CLI::App& app, std::string& path) {
  path = "rayline";
  for (const CLI::App* at = &app;;) {
    const std::vector<const CLI::App*> subs = at->get_subcommands([](const CLI::App* s) { return s->parsed(); });
    if (subs.empty()) return at;
    at = subs.front();
    path += " " + at->get_name();
  }
}

// CLI11's message, except "Could not convert: --exec-noise = abc", which becomes the form
// of the other flag errors: "--exec-noise: 'abc' is not a FLOAT".
std::string parse_message(const CLI::App& at, const CLI::ParseError& e) {
  const std::string what = e.what(), prefix = "Could not convert: ";
  const std::size_t eq = what.find(" = ");
  if (what.rfind(prefix, 0) != 0 || eq == std::string::npos) return what;
  const std::string name = what.substr(prefix.size(), eq - prefix.size());
  const CLI::Option* opt = at.get_option_no_throw(name);
  return name + ": '" + what.substr(eq + 3) + "' is not " + (opt ? "a " + opt->get_type_name() : "a valid value");
}

// A CLI11 parse error (unknown flag, bad value, missing argument) in the form of every
// other error: "rayline: render: MESSAGE (see rayline render --help)", exit 2. --help and
// --version, which CLI11 reports as errors with exit code 0, print as CLI11 prints them.
int parse_error(const CLI::App& app, const CLI::ParseError& e) {
  if (e.get_exit_code() == 0) return app.exit(e);
  std::string path;
  const CLI::App* at = parsed_command(app, path);
  std::fprintf(stderr, "rayline: %s%s (see %s --help)\n", where(path).c_str(), parse_message(*at, e).c_str(),
               path.c_str());
  return kExitBadInput;
}

// CLI11 answers a mistyped subcommand ("rayline simualte"), and a missing one, with "A
// subcommand is required". Name the word, the subcommands there are, and the closest one.
// False: every word names a subcommand (or none is needed), so CLI11 parses.
bool bad_subcommand(const CLI::App& app, int argc, char** argv) {
  const CLI::App* at = &app;
  std::string path = "rayline";
  int i = 1;
  for (; i < argc; ++i) {
    const std::string word = argv[i];
    const auto subs = at->get_subcommands(std::function<bool(const CLI::App*)>{});
    if (subs.empty() || word.empty() || word[0] == '-') return false;
    const CLI::App* next = nullptr;
    std::string closest;
    std::size_t best = 3;  // suggest only within two edits
    for (const CLI::App* sub : subs) {
      if (sub->get_name() == word) next = sub;
      if (const std::size_t d = edit_distance(word, sub->get_name()); d < best) {
        best = d;
        closest = sub->get_name();
      }
    }
    if (!next) {
      std::fprintf(stderr, "rayline: %sunknown subcommand '%s'%s (expected one of: %s; see %s --help)\n",
                   where(path).c_str(), word.c_str(), closest.empty() ? "" : (", did you mean '" + closest + "'?").c_str(),
                   subcommand_names(*at).c_str(), path.c_str());
      return true;
    }
    at = next;
    path += " " + word;
  }
  if (at->get_require_subcommand_min() == 0) return false;
  std::fprintf(stderr, "rayline: %sa subcommand is required, one of: %s (see %s --help)\n", where(path).c_str(),
               subcommand_names(*at).c_str(), path.c_str());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  rayline::cli::install_interrupt_cleanup();  // first: before any thread exists
  rayline::record_invocation(rayline::cli::version(), argc, argv);  // for every metrics.json
  CLI::App app{"Rayline: timeline scheduling for out-of-core ray batching (Son & Yoon, HPG 2017)"};
  app.set_version_flag("--version", std::string("rayline ") + rayline::cli::version());
  app.require_subcommand(1);
  std::function<int()> action;
  add_platform(app, action);
  add_plan(app, action);
#ifdef RAYLINE_WITH_SIM
  add_simulate(app, action);
  add_compare(app, action);
#endif
#ifdef RAYLINE_WITH_RENDER
  add_generate(app, action);
  add_partition(app, action);
  add_render(app, action);
  add_calibrate(app, action);
  add_devices(app, action);
#endif
  add_report(app, action);
  // New subcommands: add an add_<name>(app, action) above, call it here, and list its
  // cmd_<name>.cpp in apps/CMakeLists.txt.
  if (argc == 2 && std::string(argv[1]) == kCliReferenceFlag) {  // docs/cli.md (scripts/update_cli_reference.sh)
    std::fputs(cli_reference(app).c_str(), stdout);
    return kExitOk;
  }
  if (bad_subcommand(app, argc, argv)) return kExitBadInput;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return parse_error(app, e);
  }
  return action ? guarded(action) : kExitBadInput;
}

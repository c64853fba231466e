// `rayline render` / `rayline calibrate`: options → engine::render / engine::calibrate.
// The image is written in the format its name's extension names: IMAGE.exr (with its PNG
// preview IMAGE.png) or IMAGE.png alone; next to it IMAGE.metrics.json,
// IMAGE.timeline.json (Chrome trace), IMAGE.jobs.csv, and the recordings asked for, all
// published together once every one is written (apps/run/output_set.hpp).
#include "apps/cmd_render.hpp"


#include <cctype>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "apps/cli_common.hpp"
#include "apps/cmd_partition.hpp"
#include "apps/run/output_set.hpp"
#include "apps/run/run_options.hpp"
#include "render/engine/calibrate.hpp"
#include "render/engine/profile_recorder.hpp"
#include "render/engine/ray_log_recorder.hpp"
#include "render/engine/renderer.hpp"
#ifdef RAYLINE_WITH_MPI
#include "render/mpi/lan_calibration.hpp"
#include "render/mpi/mpi_cluster.hpp"
#endif
#include "render/image/image_io.hpp"
#include "render/scene/gltf_reader.hpp"
#include "render/scene/scene.hpp"
#include "common/error.hpp"
#include "common/progress_line.hpp"
#include "common/units.hpp"
#include "workload/twin_file.hpp"

namespace rayline::cli {

namespace fs = std::filesystem;

namespace {

void parse_resolution(const std::string& s, int& w, int& h) {
  if (s.empty()) return;
  const auto x = s.find('x');
  try {
    std::size_t p1 = 0, p2 = 0;
    if (x == std::string::npos) throw std::invalid_argument("no x");
    w = std::stoi(s.substr(0, x), &p1);
    h = std::stoi(s.substr(x + 1), &p2);
    if (p1 != x || p2 != s.size() - x - 1 || w <= 0 || h <= 0 || w > 16384 || h > 16384)
      throw std::invalid_argument("range");
  } catch (const std::exception&) {
    throw InputError("--resolution", "", "expected WIDTHxHEIGHT with 1..16384 each, e.g. 640x480; got '" + s + "'");
  }
}

std::string sibling(const std::string& image, const std::string& suffix) {
  fs::path p(image);
  return (p.parent_path() / (p.stem().string() + suffix)).string();
}

// NAME.twin.json -> NAME.twin.rays (InputError unless the name ends in .twin.json).
std::string twin_rays_file(const std::string& twin) {
  if (!twin.ends_with(".twin.json"))
    throw InputError(twin, "--record-twin", "name the file NAME.twin.json (its ray log is written as NAME.twin.rays)");
  return twin.substr(0, twin.size() - 5) + ".rays";
}

// True for an --out named .exr (OpenEXR, and its PNG preview), false for .png (the 8-bit
// sRGB image alone), any case; InputError for any other name.
bool writes_exr(const std::string& out) {
  std::string ext = fs::path(out).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (ext == ".exr" || ext == ".png") return ext == ".exr";
  throw InputError(out, "--out", "the image is written in the format its extension names: use a name ending in .exr "
                                 "(OpenEXR, with a PNG preview next to it) or .png");
}

// The files of a render's --out: the image, its PNG preview (EXR only), the metrics, the
// timeline and the jobs CSV.
std::vector<NamedPath> image_outputs(const std::string& out) {
  std::vector<NamedPath> files{{"--out", out}};
  if (writes_exr(out)) files.push_back({"--out (its PNG preview)", sibling(out, ".png")});
  files.push_back({"--out (its metrics)", sibling(out, ".metrics.json")});
  files.push_back({"--out (its timeline)", sibling(out, ".timeline.json")});
  files.push_back({"--out (its jobs CSV)", sibling(out, ".jobs.csv")});
  return files;
}

// The scene file and the mesh files a JSON scene names (resolved as the loader resolves
// them): no output may replace one of them either. (A scene that does not load is reported
// here, before any work, with the loader's message.)
std::vector<NamedPath> scene_inputs(const std::string& scene_path) {
  const auto ext = [](const std::string& path) {
    std::string e = fs::path(path).extension().string();
    for (char& ch : e) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return e;
  };
  std::vector<NamedPath> in;
  // A glTF mesh also reads its buffer files (and names its textures): outputs replace none.
  const auto add_mesh = [&](const std::string& what, const std::string& file) {
    in.push_back({what, file});
    if (ext(file) == ".gltf" || ext(file) == ".glb")
      for (const std::string& f : scene::gltf_external_files(file))
        in.push_back({what + " (its file '" + fs::path(f).filename().string() + "')", f});
  };
  if (scene_path.empty() || ext(scene_path) != ".json") {
    add_mesh("--scene", scene_path);
    return in;
  }
  in.push_back({"--scene", scene_path});
  for (const scene::MeshInstance& m : scene::load_scene(scene_path).meshes)
    if (!m.file.empty()) add_mesh("--scene (its mesh '" + m.name + "')", m.file);
  return in;
}

// The render's progress: a bar, the fraction of camera paths done and the rays per second.
// Elapsed time since the bar was made, and the time left at the rate so far (ETA).
std::function<void(double, double)> progress_bar(ProgressLine& line, const char* what) {
  const auto t0 = std::chrono::steady_clock::now();
  return [&line, what, t0](double fraction, double rays_per_s) {
    if (!line.due()) return;
    const int width = 30, n = static_cast<int>(fraction * width + 0.5);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string left =
        fraction > 0.01 && fraction < 1 ? format_duration(elapsed * (1 - fraction) / fraction) + " left" : "";
    line.print(what, "[%.*s%*s] %5.1f %%  %s  %s elapsed  %s", n, "##############################", width - n, "",
               100 * fraction, format_rate(rays_per_s, "rays").c_str(), format_duration(elapsed).c_str(), left.c_str());
  };
}

}  // namespace

namespace {

// The flags as the renderer's options (engine::RenderOptions), parsed and checked.
engine::RenderOptions render_options(const RenderCliOptions& opt) {
  engine::RenderOptions ro;
  ro.scene = opt.scene;
  ro.blocks_dir = opt.blocks_dir;
  ro.blocks = opt.blocks;
  ro.platform = opt.platform;
  ro.spp = opt.spp;
  ro.max_depth = opt.max_depth;
  ro.threads = opt.threads;
  ro.seed = opt.seed;
  const SchedulerChoice choice =
      scheduler_choice(opt.scheduler, duration_flag("--horizon", opt.horizon), parse_aging(opt.aging, "--aging"));
  ro.scheduler = std::string(scheduler_name(choice.kind));
  ro.horizon = choice.horizon;
  ro.aging = choice.aging;
  ro.adaptive_aging = choice.adaptive_aging;
  ro.faults = opt.fail;
  ro.fail_read = opt.fail_read;
  if (opt.paths > 0 && opt.paths < 64) throw InputError("--paths", "", "must be 0 (auto) or at least 64");
  ro.batching.path_cap = opt.paths;
  ro.bvh_quality = opt.bvh_quality;
  ro.read_ahead = opt.read_ahead == "on";
  ro.skip_empty = opt.skip_empty == "on";
  ro.batching.continue_in_cell = opt.continue_in_cell == "on";
  ro.batching.camera_jobs = opt.camera_jobs == "on";
  ro.loaders = opt.loaders;
  parse_resolution(opt.resolution, ro.width, ro.height);
  if (!opt.memory_budget.empty()) ro.memory_budget = size_flag("--memory-budget", opt.memory_budget);
  ro.gpu = opt.gpu;
  if (!opt.gpu_memory_budget.empty())
    ro.gpu_memory_budget = size_flag("--gpu-memory-budget", opt.gpu_memory_budget);
  return ro;
}

// Before rendering (nothing rendered for nothing): the image and its companions are
// written beside it (sibling names), and none of them, nor a recording, may be an input.
void check_render_outputs(const RenderCliOptions& opt) {
  std::error_code ec;
  if (fs::is_directory(opt.out, ec))
    throw InputError(opt.out, "--out", "is a folder; give a file name such as out/render.exr or out/render.png");
  std::vector<NamedPath> outputs = image_outputs(opt.out);
  outputs.push_back({"--record-profile", opt.record_profile});
  outputs.push_back({"--record-replay", opt.record_replay});
  outputs.push_back({"--record-twin", opt.record_twin});
  if (!opt.record_twin.empty()) outputs.push_back({"--record-twin (its ray log)", twin_rays_file(opt.record_twin)});
  std::vector<NamedPath> inputs = scene_inputs(opt.scene);
  inputs.push_back({"--platform", opt.platform == "auto" ? std::string() : opt.platform});
  inputs.push_back(
      {"--blocks-dir", opt.blocks_dir.empty() ? std::string() : (fs::path(opt.blocks_dir) / "blocks.json").string()});
  check_distinct(outputs, inputs);
  check_output_file(opt.out, "--out", "out/render.exr");
}

// --record-twin: this render as `simulate --like` runs it (workload/twin_file.hpp).
void write_twin(const RenderCliOptions& opt, engine::RayLogRecorder& rec, const engine::RenderResult& r,
                OutputSet& outputs) {
  const RayLog& log = rec.finish();
  TwinSpec t;
  t.scene = r.scene_name;
  t.width = std::uint32_t(r.width), t.height = std::uint32_t(r.height), t.spp = std::uint32_t(r.spp);
  t.max_depth = std::uint32_t(r.max_depth);
  t.seed = r.seed;
  t.scheduler = r.scheduler;
  t.horizon = duration_flag("--horizon", opt.horizon);
  t.path_cap = r.path_cap, t.min_batch = r.min_batch, t.max_batch = r.max_batch;
  t.continue_in_cell = r.continue_in_cell;
  t.camera_jobs = r.camera_jobs;
  t.memory_budget = r.memory_budget;
  t.blocks = r.block_bytes;
  const std::string rays = twin_rays_file(opt.record_twin);
  t.rays = fs::path(rays).filename().string();
  t.platform_json = r.platform_json;
  engine::CalibrationResult fit;  // this run's own Eq. 1, Eq. 2 and control loop latency
  fit.model = r.workstation;
  engine::fit_model(r, fit);
  t.fitted_platform_json = engine::workstation_json(fit.model, "fitted to the recorded render's own measurements");
  t.recorded_seconds = r.seconds;
  t.recorded_loads = r.store.loads;
  t.recorded_jobs = r.jobs;
  t.recorded_traced = r.counts.traced;
  outputs.write(rays, [&](const std::string& staged) { log.save(staged); });
  outputs.write_text(opt.record_twin, twin_json(t));
}

// --record-profile / --record-replay: the recorder the renderer's kernels report to.
std::unique_ptr<engine::ProfileRecorder> make_recorder(const RenderCliOptions& opt) {
  if (opt.record_profile.empty() && opt.record_replay.empty()) return nullptr;
  engine::ProfileRecorderOptions po;
  try {
    parse_resolution(opt.record_tiles, po.tiles_x, po.tiles_y);
  } catch (const InputError&) {
    throw InputError("--record-tiles", "", "expected TXxTY, e.g. 8x8; got '" + opt.record_tiles + "'");
  }
  po.keyframe = opt.record_keyframe;
  po.replay = !opt.record_replay.empty();
  if (!opt.record_profile.empty()) check_output_file(opt.record_profile, "--record-profile", "out/room.profile.json");
  if (!opt.record_replay.empty()) check_output_file(opt.record_replay, "--record-replay", "out/room.replay.log");
  return std::make_unique<engine::ProfileRecorder>(po);
}

void write_recordings(const RenderCliOptions& opt, const engine::ProfileRecorder& recorder, const engine::RenderResult& r,
                      OutputSet& outputs) {
  const std::string extra = "\"scene\": \"" + r.scene_name + "\", \"blocks\": " + std::to_string(r.blocks) +
                            ", \"seed\": " + std::to_string(r.seed) + ", \"render_rays\": {\"traced\": " +
                            std::to_string(r.counts.traced) + ", \"created\": " + std::to_string(r.counts.created) +
                            ", \"escaped\": " + std::to_string(r.counts.escaped) + ", \"occluded\": " +
                            std::to_string(r.counts.occluded) + ", \"unoccluded\": " +
                            std::to_string(r.counts.unoccluded) + "}";
  if (!opt.record_profile.empty()) outputs.write_text(opt.record_profile, recorder.statistics_json(extra));
  if (!opt.record_replay.empty())
    outputs.write(opt.record_replay, [&](const std::string& staged) {
      recorder.replay().save(staged, "recorded by rayline render from " + r.scene_name + ", " + std::to_string(r.width) +
                                         "x" + std::to_string(r.height) + ", " + std::to_string(r.spp) +
                                         " spp, keyframe " + std::to_string(opt.record_keyframe) + " (client 0, frame " +
                                         std::to_string(opt.record_keyframe) + ")");
    });
}

// IMAGE.exr (with the run's metadata) and IMAGE.png, or IMAGE.png alone; IMAGE.metrics.json,
// .timeline.json, .jobs.csv.
void write_image_and_companions(const std::string& out, const engine::RenderResult& r, OutputSet& outputs) {
  const bool exr = writes_exr(out);
  image::Metadata meta;
  meta.strings["rayline.scene"] = r.scene_name;
  meta.strings["rayline.scheduler"] = r.scheduler_parameters;
  meta.ints["rayline.spp"] = r.spp;
  meta.ints["rayline.seed"] = static_cast<long long>(r.seed);
  meta.ints["rayline.blocks"] = static_cast<long long>(r.blocks);
  meta.ints["rayline.max_depth"] = r.max_depth;
  meta.doubles["rayline.seconds"] = r.seconds;
  meta.doubles["rayline.memory_budget_bytes"] = static_cast<double>(r.memory_budget);
  if (exr)
    outputs.write(out, [&](const std::string& staged) { image::write_exr(staged, r.width, r.height, r.rgb.data(), meta); });
  outputs.write(exr ? sibling(out, ".png") : out, [&](const std::string& staged) {
    image::write_png_preview(staged, r.width, r.height, r.rgb.data(), 1.0f);
  });
  outputs.write_text(sibling(out, ".metrics.json"), r.metrics_json);
  outputs.write_text(sibling(out, ".timeline.json"), r.timeline_json);
  outputs.write_text(sibling(out, ".jobs.csv"), r.jobs_csv);
}

void print_render_summary(const std::string& out, const engine::RenderResult& r) {
  std::printf("rendered %dx%d, %d spp, %u blocks, %s, budget %s: %s, %s (%llu rays), %llu loads, %s read (%s)\n",
              r.width, r.height, r.spp, r.blocks, r.scheduler.c_str(),
              r.memory_budget ? format_size(double(r.memory_budget)).c_str() : "in core", format_duration(r.seconds).c_str(),
              format_rate(double(r.counts.created) / r.seconds, "rays").c_str(),
              static_cast<unsigned long long>(r.counts.created), static_cast<unsigned long long>(r.store.loads),
              format_size(double(r.store.bytes_read)).c_str(),
              r.store.buffered_reads == 0 ? "O_DIRECT" : "buffered, pages dropped");
  if (!r.gpu_device.empty())
    std::printf("gpu '%s'%s: %llu jobs, %llu rays (%llu rays on the CPU path), %llu block uploads; %s\n",
                r.gpu_device.c_str(), r.gpu_cpu_backed ? " (CPU-backed)" : "",
                static_cast<unsigned long long>(r.gpu.gpu_jobs), static_cast<unsigned long long>(r.gpu.gpu_rays),
                static_cast<unsigned long long>(r.gpu.fallback_rays),
                static_cast<unsigned long long>(r.gpu.block_uploads), r.gpu_status.c_str());
  std::string files;
  for (const NamedPath& f : image_outputs(out)) files += (files.empty() ? "" : ", ") + f.path;
  std::printf("wrote %s\n", files.c_str());
}

}  // namespace

namespace {
int render_here(const RenderCliOptions& opt, engine::Cluster* cluster);
}  // namespace

// --distributed: every rank runs this command; rank 0 renders, the others serve its plan.
int run_render(const RenderCliOptions& opt) {
  if (!opt.distributed) return render_here(opt, nullptr);
#ifdef RAYLINE_WITH_MPI
  if (!opt.record_profile.empty() || !opt.record_replay.empty() || !opt.record_twin.empty())
    throw InputError("--distributed", "", "recordings (--record-*) are made by one-machine renders only");
  // --fail Rk@TIME: rank k's process is killed at TIME (its loss is handled as a fault).
  int fail_rank = -1;
  double fail_at = 0;
  for (const std::string& f : opt.fail) {
    const auto at = f.find('@');
    int k = -1;
    try {
      if (f.size() > 1 && f[0] == 'R' && at != std::string::npos) k = std::stoi(f.substr(1, at - 1));
      fail_at = units::parse_duration(f.substr(at + 1));
    } catch (const std::exception&) {
      k = -1;
    }
    if (k < 1 || fail_rank >= 0)
      throw InputError("--fail", f, "with --distributed: one Rk@TIME, k >= 1 a rank other than the master R0, e.g. R2@1.5s");
    fail_rank = k;
  }
  mpi::Session session;
  if (fail_rank >= session.size())
    throw InputError("--fail", opt.fail.front(), "names rank " + std::to_string(fail_rank) + " of " + std::to_string(session.size()));
  mpi::MpiCluster cluster(session);
  cluster.fail_at(fail_rank, fail_at);
  if (session.rank() != 0) return cluster.serve();
  return render_here(opt, &cluster);
#else
  throw InputError("--distributed", "", "this rayline was built without MPI (scripts/setup.sh installs Open MPI; rebuild)");
#endif
}

namespace {
int render_here(const RenderCliOptions& opt, engine::Cluster* cluster) {
  engine::RenderOptions ro = render_options(opt);
  ro.cluster = cluster;
  if (cluster) ro.faults.clear();  // (a rank's loss is injected by the rank itself)
  check_render_outputs(opt);
  ProgressLine line(ProgressLine::for_stderr(opt.quiet));
  if (line.mode() != ProgressLine::Mode::Off) {
    ro.progress = progress_bar(line, "render");
    ro.partition_progress = partition_progress(line);
  }
  const std::unique_ptr<engine::ProfileRecorder> recorder = make_recorder(opt);
  ro.batching.recorder = recorder.get();
  std::unique_ptr<engine::RayLogRecorder> ray_log;
  if (!opt.record_twin.empty()) {
    check_output_file(opt.record_twin, "--record-twin", "out/room.twin.json");
    ray_log = std::make_unique<engine::RayLogRecorder>();
    ro.batching.ray_log = ray_log.get();
  }
  const engine::RenderResult r = engine::render(ro);
  line.done();
  OutputSet outputs;
  if (recorder) write_recordings(opt, *recorder, r, outputs);
  if (ray_log) write_twin(opt, *ray_log, r, outputs);
  write_image_and_companions(opt.out, r, outputs);
  outputs.publish();
  if (!opt.quiet) print_render_summary(opt.out, r);
  return kExitOk;
}
}  // namespace

// One fit's quality for the console (sched/core/fit_errors.hpp): the error on the measured time
// first, since the worst relative error belongs to the shortest samples.
std::string fit_quality(const FitErrors& f, const char* sample) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "error %.0f %% of the measured time (median %s %.0f %%, RMS %s, worst %.0f %%)",
                100 * f.weighted_rel, sample, 100 * f.median_rel, format_duration(f.rms).c_str(), 100 * f.max_rel);
  return buf;
}

namespace {
// Eq. 2's rate (seconds per byte of 64-byte ray records) as rays per second.
std::string ray_rate(double seconds_per_byte) { return format_rate(1.0 / (seconds_per_byte * 64), "rays"); }
}  // namespace

// What a poor fit means for the user, when a fit misses the measured times by more than a
// third: plans on this platform file mis-time jobs by about as much. Other programs
// competing for the cores are the common cause (a busy 2-core machine gave 60-120 %).
void print_fit_advice(const engine::CalibrationResult& c) {
  constexpr double kPoor = 0.33;
  const std::pair<const char*, const FitErrors*> fits[] = {
      {"disk loads", &c.load_fit}, {"RayIntersect", &c.intersect_fit}, {"ShadowIntersect", &c.shadow_fit}};
  std::string poor;
  for (const auto& [name, f] : fits)
    if (f->weighted_rel > kPoor) poor += std::string(poor.empty() ? "" : ", ") + name;
  if (poor.empty()) return;
  std::printf("advice: the fits of %s miss the measured times by more than %.0f %%, so plans made with this file will "
              "mis-time those jobs by about as much (jobs.csv and rayline report show planned against actual). "
              "Programs competing for the cores are the usual cause: calibrate again on an otherwise idle machine. "
              "The file is written and usable.\n",
              poor.c_str(), 100 * kPoor);
}

namespace {
// What `calibrate --distributed` measured of the LAN: the ranks, the file's model, the lines
// to print.
struct ClusterLan {
  int ranks = 1;
  engine::LanModel model;
  std::string report;
};
int calibrate_here(const CalibrateCliOptions& opt, const ClusterLan* lan, int local_ranks);
}  // namespace

// --distributed: every rank measures the LAN with the others; rank 0 then calibrates its node
// and writes the cluster's platform file (one node per rank, every node like rank 0's).
int run_calibrate(const CalibrateCliOptions& opt) {
  if (!opt.distributed) return calibrate_here(opt, nullptr, 1);
#ifdef RAYLINE_WITH_MPI
  mpi::Session session;
  const mpi::LanMeasurement m = mpi::measure_lan(session);
  if (session.rank() != 0) return kExitOk;
  ClusterLan lan{m.ranks, m.model, ""};
  char line[200];
  for (int i = 0; i < m.ranks; ++i)
    for (int j = i + 1; j < m.ranks; ++j) {
      std::snprintf(line, sizeof line, "LAN R%d<->R%d, Eq. 1 by ping-pong: latency %s, bandwidth %s\n", i, j,
                    format_duration(m.latency[i][j]).c_str(), format_bandwidth(m.bandwidth[i][j]).c_str());
      lan.report += line;
    }
  std::string nics;
  for (std::size_t r = 0; r < m.model.nic.size(); ++r)
    nics += (r ? ", R" : "R") + std::to_string(r) + " " + format_bandwidth(m.model.nic[r]);
  if (m.ranks > 1)
    lan.report += "the platform file's LAN: latency " + format_duration(m.model.latency) +
                  " (median of the pairs), NICs " + nics + " (each the median of its pairs)\n";
  return calibrate_here(opt, &lan, session.local_size());
#else
  throw InputError("--distributed", "", "this rayline was built without MPI (scripts/setup.sh installs Open MPI; rebuild)");
#endif
}

namespace {
int calibrate_here(const CalibrateCliOptions& opt, const ClusterLan* lan, int local_ranks) {
  engine::RenderOptions ro;
  ro.scene = opt.scene;
  ro.blocks = opt.blocks;
  ro.threads = opt.threads;
  if (lan && opt.threads == 0)  // the node's share of this machine, as a distributed render's default
    ro.threads = std::max(1, int(std::thread::hardware_concurrency()) / std::max(1, local_ranks));
  ro.spp = opt.spp;
  ro.gpu = opt.gpu;
  ro.bvh_quality = opt.bvh_quality;
  parse_resolution(opt.resolution, ro.width, ro.height);
  if (!(opt.budget_fraction > 0 && opt.budget_fraction < 1))
    throw InputError("--budget-fraction", "", "must be in (0, 1)");
  check_distinct({{"--out", opt.out}}, scene_inputs(opt.scene));
  check_output_file(opt.out, "--out", "out/this-machine.json");
  ProgressLine line(ProgressLine::for_stderr(opt.quiet));
  if (line.mode() != ProgressLine::Mode::Off) {
    ro.progress = progress_bar(line, "calibrate");
    ro.partition_progress = partition_progress(line);
  }
  engine::CalibrationResult c = engine::calibrate(ro, opt.budget_fraction, engine::kMinGpuJobsPerType, opt.repeats, opt.passes);
  line.done();
  if (lan) {
    c.platform_json = engine::cluster_json(c.model, lan->ranks, engine::lan_for_plan(lan->model, c.model),
                                           "calibrated by rayline calibrate --distributed on " + std::to_string(lan->ranks) +
                                               " ranks: every node as rank 0's");
    std::fputs(lan->report.c_str(), stdout);
  }
  write_file_atomic(opt.out, c.platform_json);
  std::printf("fitted to the measuring render of median wall time (%s) of %d%s\n", format_duration(c.median_render_seconds).c_str(),
              c.repeats, c.passes > 1 ? ", planned on a first render's fit" : "");
  std::printf("disk->RAM (read + BVH build), Eq. 1 over %d loads: latency %s, bandwidth %s with the CPU threads "
              "idle, x%.2f the time with all of them busy; %s\n",
              c.load_samples, format_duration(c.model.disk_latency).c_str(), format_bandwidth(c.model.disk_bandwidth).c_str(),
              1 + c.model.disk_cpu_contention, fit_quality(c.load_fit, "load").c_str());
  std::printf("CPU threads' jobs beside a load run x%.2f slower (over %d such jobs; Eq. 2 below from the others)\n",
              1 + c.model.disk_exec_contention, c.beside_load_samples);
  std::printf("control loop after a finished job, over %d waits of a thread that ran dry: %s + %.3g x the job's "
              "duration (mean wait per job %s); %s\n",
              c.loop_samples, format_duration(c.model.loop.per_job).c_str(), c.model.loop.per_exec_second,
              format_duration(c.dispatch_gap).c_str(), fit_quality(c.loop_fit, "wait").c_str());
  std::printf("loader woken after another thread's job, mean over %d loads: %s\n", c.wake_samples,
              c.wake_samples >= 10 ? format_duration(c.model.loop.wake).c_str() : "too few to fit (0)");
  std::printf("thread's hand-over to a job dispatched before it ran dry, mean over %d jobs: %s\n", c.pickup_samples,
              c.pickup_samples >= 10 ? format_duration(c.model.loop.pickup).c_str() : "too few to fit (0)");
  std::printf("loop's first wave of camera rays: %s per ray\n", format_duration(c.model.loop.per_camera_ray).c_str());
  std::printf("RayIntersect per thread, Eq. 2 over %d jobs: setup %s, %s; %s\n", c.exec_samples,
              format_duration(c.model.intersect_setup).c_str(), ray_rate(c.model.intersect_rate).c_str(),
              fit_quality(c.intersect_fit, "job").c_str());
  std::printf("ShadowIntersect per thread: setup %s, %s; %s\n", format_duration(c.model.shadow_setup).c_str(),
              ray_rate(c.model.shadow_rate).c_str(), fit_quality(c.shadow_fit, "job").c_str());
  if (!c.model.gpus.empty()) {
    const engine::GpuModel& gm = c.model.gpus[0];
    if (c.gpu_pass)
      std::printf("the measuring render gave the GPU %d RayIntersect and %d ShadowIntersect jobs (GPU %s), fewer than "
                  "%d of a type: measured it in a second render with its jobs planned on the GPU alone\n",
                  c.gpu_mixed_jobs[0], c.gpu_mixed_jobs[1], c.gpu_mixed_status.c_str(), engine::kMinGpuJobsPerType);
    std::printf("GPU '%s' over %d jobs: RayIntersect setup %s, %s%s; ShadowIntersect setup %s, %s%s\n",
                c.gpu_device.c_str(), c.gpu_exec_samples, format_duration(gm.intersect_setup).c_str(),
                ray_rate(gm.intersect_rate).c_str(), c.gpu_intersect_fitted ? "" : " (defaults kept: no usable fit)",
                format_duration(gm.shadow_setup).c_str(), ray_rate(gm.shadow_rate).c_str(),
                c.gpu_shadow_fitted ? "" : " (defaults kept: no usable fit)");
    if (c.gpu_intersect_fitted) std::printf("  GPU RayIntersect: %s\n", fit_quality(c.gpu_intersect_fit, "job").c_str());
    if (c.gpu_shadow_fitted) std::printf("  GPU ShadowIntersect: %s\n", fit_quality(c.gpu_shadow_fit, "job").c_str());
    std::printf("RAM->GPU channel, Eq. 1 over %d uploads: latency %s, bandwidth %s; %s\n", c.pcie_samples,
                format_duration(gm.pcie_latency).c_str(), format_bandwidth(gm.pcie_bandwidth).c_str(),
                fit_quality(c.pcie_fit, "upload").c_str());
  }
  print_fit_advice(c);
  std::printf("wrote %s (use: %srayline render %s--platform %s)\n", opt.out.c_str(), lan ? "mpirun -np N " : "",
              lan ? "--distributed " : "", opt.out.c_str());
  return kExitOk;
}
}  // namespace

}  // namespace rayline::cli

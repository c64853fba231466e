#include "render/engine/calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "render/store/temp_partition.hpp"
#include "sched/core/data_block.hpp"
#include "sched/core/nnls.hpp"
#include "sched/core/timing_model.hpp"

namespace rayline::engine {

namespace {

// Least squares of t = lat + bytes / bw (Eq. 1; closed form for one regressor).
FitErrors fit_channel(const std::vector<std::pair<Bytes, Time>>& s, Time& latency, double& bandwidth) {
  const double n = double(s.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (auto [b, t] : s) sx += double(b), sy += t, sxx += double(b) * double(b), sxy += double(b) * t;
  const double den = n * sxx - sx * sx;
  double slope = den > 0 ? (n * sxy - sx * sy) / den : 0, icpt = den > 0 ? (sy - slope * sx) / n : 0;
  if (!(slope > 0)) {  // all loads of one size, or noise: bandwidth from the totals
    slope = sx > 0 ? sy / sx : 1e-9;
    icpt = 0;
  }
  if (icpt < 0) {  // a negative latency is not physical: refit through the origin
    slope = sxx > 0 ? sxy / sxx : slope;
    icpt = 0;
  }
  latency = icpt;
  bandwidth = 1.0 / slope;
  std::vector<double> pred, meas;
  for (auto [b, t] : s) {
    pred.push_back(icpt + slope * double(b));
    meas.push_back(t);
  }
  return fit_errors(pred, meas);
}

// Eq. 1 of the disk->RAM channel with the CPU threads' share in it (Channel::cpu_contention):
//   t = lat + bytes / bw x (1 + contention x busy),
// busy the threads' mean busy share while the load ran (its BVH build shares the cores),
// by non-negative least squares over [bytes, bytes x busy] and, when the loads' sizes
// differ enough to tell it from the slope, [1] (even median-split blocks are all about one
// size: then lat = 0, as fit_channel does). Loads that all saw about the same share cannot
// tell the two slopes apart: then Eq. 1 alone, contention 0.
FitErrors fit_load_channel(const std::vector<RenderResult::LoadSample>& s, Time& latency, double& bandwidth,
                           double& contention) {
  contention = 0;
  double lo = 1, hi = 0;
  Bytes small = ~Bytes(0), large = 0;
  for (const auto& x : s) {
    lo = std::min(lo, x.busy), hi = std::max(hi, x.busy);
    small = std::min(small, x.bytes), large = std::max(large, x.bytes);
  }
  if (s.size() >= 3 && hi - lo >= 0.25 && small > 0) {
    const bool with_latency = double(large) >= 1.5 * double(small);
    const int cols = with_latency ? 3 : 2;
    constexpr double kMB = 1e6;  // columns of like magnitude
    std::vector<double> a, t;
    for (const auto& x : s) {
      const double mb = double(x.bytes) / kMB;
      if (with_latency) a.push_back(1.0);
      a.insert(a.end(), {mb, mb * x.busy});
      t.push_back(x.seconds);
    }
    const NnlsResult f = solve_nnls(a, int(s.size()), cols, t);
    const double slope = f.ok ? f.x[cols - 2] : 0;
    if (slope > 0) {
      latency = with_latency ? f.x[0] : 0;
      bandwidth = kMB / slope;
      contention = f.x[cols - 1] / slope;
      std::vector<double> pred, meas;
      for (const auto& x : s) {
        pred.push_back(latency + double(x.bytes) / bandwidth * (1 + contention * x.busy));
        meas.push_back(x.seconds);
      }
      return fit_errors(pred, meas);
    }
  }
  std::vector<std::pair<Bytes, Time>> plain;
  for (const auto& x : s) plain.emplace_back(x.bytes, x.seconds);
  return fit_channel(plain, latency, bandwidth);
}

}  // namespace

void fit_model(const RenderResult& r, CalibrationResult& c) {
  c.load_samples = static_cast<int>(r.load_samples.size());
  if (r.load_samples.size() >= 2)
    c.load_fit = fit_load_channel(r.load_samples, c.model.disk_latency, c.model.disk_bandwidth, c.model.disk_cpu_contention);

  // All CPU hardware threads are identical: fit them as one device (0); the GPU is device 1.
  // A CPU thread's jobs that ran beside a load ran slower (its BVH build takes cores):
  // Eq. 2 is fitted to the jobs that ran beside none, when there are enough of them, and
  // the slowdown (Channel::exec_contention) to the others below.
  TimingModel tm;
  tm.resize(2, 2);
  constexpr double kQuiet = 0.02;  // a job beside loads for under 2 % of its time ran beside none
  auto share = [&](std::size_t i) { return i < r.exec_load_share.size() ? r.exec_load_share[i] : 0.0; };
  std::size_t cpu = 0, quiet = 0;
  for (std::size_t i = 0; i < r.exec_samples.size(); ++i)
    if (r.exec_samples[i].device != r.gpu_device_id) {
      ++cpu;
      quiet += share(i) < kQuiet;
    }
  const bool quiet_only = quiet >= 100 && 2 * quiet >= cpu;
  std::vector<TimingSample> eq2;
  std::vector<std::pair<TimingSample, double>> beside;  // CPU samples beside loads, with their share
  for (std::size_t i = 0; i < r.exec_samples.size(); ++i) {
    TimingSample s = r.exec_samples[i];
    s.device = s.device == r.gpu_device_id ? 1 : 0;
    (s.device == 1 ? c.gpu_exec_samples : c.exec_samples) += 1;
    // Eq. 2 with the ray queue as the only sized input (SceneData's cost is in SETUP).
    std::erase_if(s.inputs, [](const InputSize& x) { return x.kind == DataKind::SceneData; });
    if (s.device == 0 && quiet_only && share(i) >= kQuiet)
      beside.emplace_back(std::move(s), share(i));  // for the slowdown fit below, not Eq. 2's
    else
      eq2.push_back(std::move(s));
  }
  // RenderResult's sample types: RayIntersect 0, ShadowIntersect 1.
  for (auto& e : tm.fit(eq2).entries) {
    if (!e.ok) continue;
    FitErrors& f = e.device == 0 ? (e.type == 0 ? c.intersect_fit : c.shadow_fit)
                                 : (e.type == 0 ? c.gpu_intersect_fit : c.gpu_shadow_fit);
    f = e.errors;
  }
  const ExecCoefficients& a = tm.at(0, 0);
  const ExecCoefficients& b = tm.at(0, 1);
  // The slowdown beside loads: t = Eq. 2 x (1 + exec_contention x share), least squares
  // through the origin over the jobs that ran beside loads.
  c.model.disk_exec_contention = 0;
  c.beside_load_samples = static_cast<int>(beside.size());
  if (beside.size() >= 20) {
    double num = 0, den = 0;
    for (const auto& [x, sh] : beside) {
      const Time pred = tm.exec_time(0, x.type, x.inputs);
      if (pred == kNever) continue;
      num += pred * sh * (x.duration - pred);
      den += (pred * sh) * (pred * sh);
    }
    if (den > 0) c.model.disk_exec_contention = std::clamp(num / den, 0.0, 10.0);
  }
  double gaps = 0;
  for (Time g : r.dispatch_gaps) gaps += g;
  c.dispatch_gap = r.dispatch_gaps.empty() ? 0 : gaps / double(r.dispatch_gaps.size());
  // The control loop's latency after a finished job (DeviceGraph::loop), fitted to the
  // gaps of threads that ran dry: gap = per_job + per_exec_second x the job's duration.
  if (r.loop_samples.size() >= 2) {
    std::vector<std::pair<Bytes, Time>> s;  // (microseconds of the finished job, gap): Eq. 1's fit
    for (auto [len, gap] : r.loop_samples) s.emplace_back(static_cast<Bytes>(len * 1e6), gap);
    double bw = 0;
    c.loop_fit = fit_channel(s, c.model.loop.per_job, bw);
    c.model.loop.per_exec_second = bw > 0 && bw < 1e15 ? 1e6 / bw : 0;
    c.loop_samples = static_cast<int>(r.loop_samples.size());
  }
  // The first wave of camera rays, made by the loop before its first plan
  // (ControlLoop::per_camera_ray): that plan's time over the wave's rays. A render of one
  // block makes its camera rays in its jobs (camera jobs): no wave, nothing to fit.
  if (r.first_wave_camera_rays > 0 && r.first_plan_at > 0)
    c.model.loop.per_camera_ray = r.first_plan_at / double(r.first_wave_camera_rays);
  // The thread's hand-over to an E-job dispatched before it ran dry (ControlLoop::pickup)
  // and the loader's wake-up (ControlLoop::wake): each the mean of its samples, as the
  // simulator adds it to each such job or load, from ten samples on (else kept).
  auto mean_of_ten_or_more = [](const std::vector<Time>& w, Time& out) {
    if (w.size() < 10) return;
    double sum = 0;
    for (Time x : w) sum += x;
    out = sum / double(w.size());
  };
  c.pickup_samples = static_cast<int>(r.pickup_samples.size());
  mean_of_ten_or_more(r.pickup_samples, c.model.loop.pickup);
  c.wake_samples = static_cast<int>(r.wake_samples.size());
  mean_of_ten_or_more(r.wake_samples, c.model.loop.wake);
  if (a.supported && a.rate[int(DataKind::RayQueue)] > 0) {
    c.model.intersect_setup = a.setup;
    c.model.intersect_rate = a.rate[int(DataKind::RayQueue)];
  }
  if (b.supported && b.rate[int(DataKind::ShadowRayQueue)] > 0) {
    c.model.shadow_setup = b.setup;
    c.model.shadow_rate = b.rate[int(DataKind::ShadowRayQueue)];
  }
  // The GPU: its Eq. 2 per job type (dispatch + hit download + host shading) and
  // the RAM->GPU channel's Eq. 1 over every upload (blocks with their BVH build, ray queues).
  if (r.gpu_device_id >= 0) {
    GpuModel gm = c.model.gpus.empty() ? GpuModel{} : c.model.gpus.front();  // what is not fitted is kept
    gm.memory = r.gpu_memory_budget;
    const ExecCoefficients& ga = tm.at(1, 0);
    const ExecCoefficients& gb = tm.at(1, 1);
    if (ga.supported && ga.rate[int(DataKind::RayQueue)] > 0) {
      gm.intersect_setup = ga.setup;
      gm.intersect_rate = ga.rate[int(DataKind::RayQueue)];
      c.gpu_intersect_fitted = true;
    }
    if (gb.supported && gb.rate[int(DataKind::ShadowRayQueue)] > 0) {
      gm.shadow_setup = gb.setup;
      gm.shadow_rate = gb.rate[int(DataKind::ShadowRayQueue)];
      c.gpu_shadow_fitted = true;
    }
    c.pcie_samples = static_cast<int>(r.pcie_samples.size());
    if (r.pcie_samples.size() >= 2) c.pcie_fit = fit_channel(r.pcie_samples, gm.pcie_latency, gm.pcie_bandwidth);
    c.gpu_device = r.gpu_device;
    c.model.gpus.assign(1, gm);
  }
}

namespace {
// The render of median wall time (`runs` is left empty): a machine shared with other work
// runs slow for a while now and then (docs/validation.md).
RenderResult take_median(std::vector<RenderResult>& runs) {
  const auto mid = runs.begin() + static_cast<std::ptrdiff_t>(runs.size() / 2);
  std::nth_element(runs.begin(), mid, runs.end(), [](const RenderResult& a, const RenderResult& b) { return a.seconds < b.seconds; });
  RenderResult r = std::move(*mid);
  runs.clear();
  return r;
}
}  // namespace

CalibrationResult calibrate(RenderOptions opt, double budget_fraction, int min_gpu_jobs, int repeats, int passes) {
  if (opt.memory_budget == 0) {
    // One quick in-core pass to learn the block sizes, then the budgeted run that loads.
    RenderOptions probe = opt;
    probe.spp = 1;
    probe.width = probe.height = 8;
    probe.keep_schedule_outputs = false;
    const RenderResult r0 = render(probe);
    opt.memory_budget = static_cast<Bytes>(double(r0.scene_block_bytes) * budget_fraction);
  }
  opt.keep_schedule_outputs = false;
  // The mixed render partitions into a folder the GPU's own pass (below) reuses; with no
  // --blocks-dir that folder is temporary, here rather than inside render().
  std::optional<TempPartition> tmp;
  const std::string blocks_dir = !opt.blocks_dir.empty() ? opt.blocks_dir : tmp.emplace().path();
  opt.blocks_dir = blocks_dir;
  // The measuring render `repeats` times; the fit takes the one of median wall time. A
  // shared machine runs slow for a while now and then: one render in such a spell would
  // make every prediction from the file slow by as much (docs/validation.md).
  std::vector<RenderResult> runs;
  if (opt.cluster) passes = 1;  // a distributed render plans on a cluster file, not on a model in memory
  const int first_repeats = passes > 1 ? 1 : std::max(1, repeats);  // the later pass is the one fitted
  for (int k = 0; k < first_repeats; ++k) runs.push_back(render(opt));
  RenderResult r = take_median(runs);
  CalibrationResult c;
  c.repeats = std::max(1, repeats);
  c.median_render_seconds = r.seconds;
  // The GPU's own pass. GMB gives the GPU only the work its (so far uncalibrated) model says
  // it finishes soonest; where the CPU threads keep up (an H200 beside 16 cores, measured:
  // 0 GPU jobs and 0 uploads in the pass above) nothing would be measured and the defaults
  // would stay. Then the same render again with every job the GPU can run planned there
  // (RenderOptions::plan_gpu_only; the doubtful rays still go to the CPU threads): its GPU
  // jobs and RAM->GPU uploads join the samples, its CPU jobs do not.
  if (r.gpu_device_id >= 0) {
    c.gpu_mixed_status = r.gpu_status;
    int* per_type = c.gpu_mixed_jobs;
    for (const TimingSample& s : r.exec_samples)
      if (s.device == r.gpu_device_id) ++per_type[s.type == 0 ? 0 : 1];
    if (per_type[0] < min_gpu_jobs || per_type[1] < min_gpu_jobs || r.pcie_samples.size() < 2) {
      RenderOptions g = opt;
      g.plan_gpu_only = true;
      g.blocks_dir = blocks_dir;  // the mixed render's partition, not a second one
      const RenderResult rg = render(g);
      c.gpu_pass = true;
      if (rg.gpu_device_id >= 0) {
        for (TimingSample s : rg.exec_samples)
          if (s.device == rg.gpu_device_id) {
            s.device = r.gpu_device_id;
            r.exec_samples.push_back(std::move(s));
          }
        r.pcie_samples.insert(r.pcie_samples.end(), rg.pcie_samples.begin(), rg.pcie_samples.end());
      }
    }
  }
  c.model.threads = r.threads;
  if (r.load_samples.size() < 2) throw std::runtime_error("calibrate: fewer than 2 block loads were measured; use more blocks");
  fit_model(r, c);
  // Later passes: renders planned on the previous fit, as the renders that use the file will
  // be. Planned on the default platform, GMB makes other jobs and waits (on the 1 M museum
  // at 25 %, a mean dispatch gap of 250-290 us against 430-540 us), and the fit measured there
  // predicted those renders 14-17 % fast (docs/validation.md). What a pass leaves unfitted
  // (the GPU's types when it got too few jobs) is kept from the one before.
  for (int pass = 1; pass < passes; ++pass) {
    const WorkstationModel first = c.model;
    RenderOptions o = opt;
    o.model = &first;
    o.platform = "<calibrate's fit, pass " + std::to_string(pass) + ">";
    for (int k = 0; k < std::max(1, repeats); ++k) runs.push_back(render(o));
    RenderResult rp = take_median(runs);
    c.median_render_seconds = rp.seconds;
    if (rp.load_samples.size() >= 2) fit_model(rp, c);
  }
  c.passes = std::max(1, passes);
  c.platform_json = workstation_json(c.model, "calibrated by rayline calibrate on this machine");
  return c;
}

}  // namespace rayline::engine

#include "render/engine/calibrate.hpp"

#include <cmath>
#include <stdexcept>

#include "sched/data_block.hpp"
#include "sched/timing_model.hpp"

namespace rayline::engine {

namespace {

// Least squares of t = lat + bytes / bw (closed form for one regressor).
void fit_channel(const std::vector<std::pair<Bytes, Time>>& s, WorkstationModel& m, double& rel_rms) {
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
  m.disk_latency = icpt;
  m.disk_bandwidth = 1.0 / slope;
  double e2 = 0;
  for (auto [b, t] : s) {
    const double pred = icpt + slope * double(b);
    if (t > 0) e2 += (pred - t) * (pred - t) / (t * t);
  }
  rel_rms = std::sqrt(e2 / n);
}

}  // namespace

CalibrationResult calibrate(RenderOptions opt, double budget_fraction) {
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
  const RenderResult r = render(opt);
  CalibrationResult c;
  c.model.threads = r.threads;
  if (r.load_samples.size() < 2) throw std::runtime_error("calibrate: fewer than 2 block loads were measured; use more blocks");
  c.load_samples = static_cast<int>(r.load_samples.size());
  fit_channel(r.load_samples, c.model, c.load_rel_rms);

  // All CPU hardware threads are identical: fit them as one device.
  TimingModel tm;
  tm.resize(1, 2);
  std::vector<TimingSample> samples;
  for (TimingSample s : r.exec_samples) {
    s.device = 0;
    // Eq. 2 with the ray queue as the only sized input (SceneData's cost is in SETUP).
    std::vector<InputSize> in;
    for (const InputSize& x : s.inputs)
      if (x.kind != DataKind::SceneData) in.push_back(x);
    s.inputs = std::move(in);
    samples.push_back(std::move(s));
  }
  c.exec_samples = static_cast<int>(samples.size());
  // RenderResult's sample types: RayIntersect 0, ShadowIntersect 1.
  for (auto& e : tm.fit(samples).entries) {
    if (!e.ok) continue;
    (e.type == 0 ? c.intersect_max_rel : c.shadow_max_rel) = e.max_rel_error;
    (e.type == 0 ? c.intersect_rms : c.shadow_rms) = e.rms_error;
  }
  const ExecCoefficients& a = tm.at(0, 0);
  const ExecCoefficients& b = tm.at(0, 1);
  if (a.supported && a.rate[int(DataKind::RayQueue)] > 0) {
    c.model.intersect_setup = a.setup;
    c.model.intersect_rate = a.rate[int(DataKind::RayQueue)];
  }
  if (b.supported && b.rate[int(DataKind::ShadowRayQueue)] > 0) {
    c.model.shadow_setup = b.setup;
    c.model.shadow_rate = b.rate[int(DataKind::ShadowRayQueue)];
  }
  c.platform_json = workstation_json(c.model, "calibrated by rayline calibrate on this machine");
  return c;
}

}  // namespace rayline::engine

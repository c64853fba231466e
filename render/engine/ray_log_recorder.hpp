// Records a render's ray log (workload/ray_log.hpp) for its simulated twin: each camera
// ray's first visit, and after every E-job which visits each of its input rays handed on.
// Runs on the loop thread (RenderWorkload calls it as each job's result is taken), from
// the job's input and output rays: an output ray descends from the input ray of the same
// path (pixel, sample) — in a RayIntersect job there is one path ray per path; in a
// ShadowIntersect job the one with the output's bounce. The render is CPU-only while
// recording (doubtful GPU rays would come back as visits of their own).
#pragma once
#include <cstdint>
#include <span>
#include <unordered_map>

#include "render/integrator/ray.hpp"
#include "workload/ray_log.hpp"

namespace rayline::engine {

class RayLogRecorder {
 public:
  void begin(std::uint32_t width, std::uint32_t height, std::uint32_t spp, std::uint32_t cells);
  // Camera rays [first, first + n) were generated; `placed` holds those that entered a cell.
  void camera_rays(std::span<const trace::RayRecord> placed, std::uint64_t first, std::uint64_t n);
  // A finished E-job: its input rays (all in one cell, one kind) and its output rays.
  void job(std::span<const trace::RayRecord> in, std::span<const trace::RayRecord> out);
  // The log, once the render has ended (every ray ended: no live ray is left).
  const RayLog& log() const { return log_; }
  std::size_t live() const { return live_.size(); }

 private:
  std::uint64_t camera_index(const trace::RayRecord& r) const {
    return std::uint64_t(r.sample) * pixels_ + r.pixel;
  }
  std::uint64_t key(const trace::RayRecord& r) const;
  std::uint32_t add_visit(const trace::RayRecord& r);

  RayLog log_;
  std::uint64_t pixels_ = 0;
  std::unordered_map<std::uint64_t, std::uint32_t> live_;  // ray (path, bounce, kind) -> its current visit
};

}  // namespace rayline::engine

// Records a render's ray log (workload/ray_log.hpp) for its simulated twin. During the
// render it only appends: the worker thread that ran an E-job keeps its input rays'
// identities (id(), 8 bytes a ray) and frees the rays as usual; the loop thread appends
// them with the job's output rays and their cells (about 20 bytes per ray visit, in
// chunks: no reallocation copies). finish() links them into the log after the render.
//
// Linking: an output ray descends from the job's input ray of the same path (pixel,
// sample) — a RayIntersect job holds one path ray per path; in a ShadowIntersect job, from
// the input of the output's bounce. The render is CPU-only while recording (a GPU's
// doubtful rays would come back as visits of their own).
#pragma once
#include <cstdint>
#include <deque>
#include <span>
#include <vector>

#include "render/integrator/ray.hpp"
#include "workload/ray_log.hpp"

namespace rayline::engine {

class RayLogRecorder {
 public:
  void begin(std::uint32_t width, std::uint32_t height, std::uint32_t spp, std::uint32_t cells);
  // Camera rays were generated; `placed` holds those that entered a cell.
  void camera_rays(std::span<const trace::RayRecord> placed);
  // A ray's identity: camera index << 9 | bounce << 1 | kind (thread-safe; throws
  // std::runtime_error past 255 bounces).
  std::uint64_t id(const trace::RayRecord& r) const;
  // A finished E-job in `cell`: its input rays' ids (one kind) and its output rays.
  void job(std::uint32_t cell, std::span<const std::uint64_t> in, std::span<const trace::RayRecord> out);
  // After the render: links what was appended into the log (std::runtime_error when a ray
  // cannot be linked, or rays are left alive).
  const RayLog& finish();

 private:
  struct Rec {
    std::uint64_t key;  // camera index << 9 | bounce << 1 | kind
    std::uint32_t cell;
  };
  RayLog log_;
  std::uint64_t pixels_ = 0;
  // Appended in event order: per event a header {kind: 0 camera / 1 job, counts} then its rays.
  struct Event {
    bool camera = false;
    std::uint32_t in = 0, out = 0;  // camera: `out` rays placed
  };
  std::deque<Event> events_;
  std::deque<Rec> rays_;
  bool finished_ = false;
};

}  // namespace rayline::engine

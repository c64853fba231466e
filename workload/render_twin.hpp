// The simulated twin of a render (docs/validation.md): the renderer's own batching policy
// (workload/ray_batch_workload.hpp, the same code `rayline render` runs) over the rays of
// a ray log recorded from that render (workload/ray_log.hpp). A twin ray is a visit of
// the log; when its E-job ends, the log says which rays it handed on and to which cells,
// exactly as the real kernels did. What the simulator adds is time: E-jobs take what the
// timing model (Eq. 2) says, T-jobs what SimGrid says for the platform's channels.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "workload/ray_batch_workload.hpp"
#include "workload/ray_log.hpp"

namespace rayline {

struct TwinRay {
  std::uint32_t visit = 0;
  std::uint32_t cell = 0;
  std::uint8_t kind = 0;  // 0 path, 1 shadow
};

struct TwinCounts {
  std::uint64_t traced = 0;       // block visits
  std::uint64_t paths_ended = 0;  // camera rays that missed every cell included
  std::uint64_t ended_here = 0;   // rays that ended in a cell (no child)
  TwinCounts& operator+=(const TwinCounts& o) {
    traced += o.traced, paths_ended += o.paths_ended, ended_here += o.ended_here;
    return *this;
  }
};

struct TwinRayTraits {
  static int slot(const TwinRay& r) { return r.kind; }
};

class RenderTwinWorkload final : public RayBatchWorkload<TwinRay, TwinCounts, TwinRayTraits> {
 public:
  // `scene_blocks[c]` is cell c's SceneData block (log->cells of them).
  RenderTwinWorkload(const DeviceGraph& g, MemId ram, std::vector<BlockId> scene_blocks, RayBatchOptions opt,
                     std::shared_ptr<const RayLog> log);

 private:
  TwinCounts make_camera_rays(std::uint64_t first, std::uint64_t n) override;
  void job_done(Job& job) override;

  std::shared_ptr<const RayLog> log_;
};

}  // namespace rayline

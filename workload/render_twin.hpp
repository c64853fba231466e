// The simulated twin of a render (docs/validation.md): the renderer's own batching policy
// (workload/ray_batch_workload.hpp, the same code `rayline render` runs) over rays whose
// outcomes come from an oracle (workload/twin_oracle.hpp): the render's ray log, replayed
// exactly, or its Markov statistics. When an E-job ends, the oracle says which rays each
// of its rays handed on and to which cells. What the simulator adds is time: E-jobs take
// what the timing model (Eq. 2) says, T-jobs what SimGrid says for the platform's channels.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "workload/ray_batch_workload.hpp"
#include "workload/twin_oracle.hpp"

namespace rayline {

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
  // `scene_blocks[c]` is cell c's SceneData block (one per cell of the recorded render).
  RenderTwinWorkload(const DeviceGraph& g, MemId ram, std::vector<BlockId> scene_blocks, RayBatchOptions opt,
                     std::unique_ptr<TwinOracle> oracle);

 private:
  TwinCounts make_camera_rays(std::uint64_t first, std::uint64_t n) override;
  void job_done(Job& job) override;

  std::unique_ptr<TwinOracle> oracle_;
};

}  // namespace rayline

// The one place where a compute device of the workstation's DCG (Fig. 2) gets its
// traversal engine: the aggregate its E-jobs run on (render/accel/aggregate.hpp).
#pragma once
#include <memory>

#include "render/accel/aggregate.hpp"
#include "sched/core/device_graph.hpp"

namespace rayline::engine {

class BlockStore;
class GpuStore;
class ProfileRecorder;

struct AggregateSources {
  BlockStore& ram;                      // scene blocks in RAM (every CPU thread's memory)
  GpuStore* gpu = nullptr;              // scene blocks and ray queues on the GPU opened, if any
  ProfileRecorder* recorder = nullptr;  // per-cell statistics of every CPU ray, if recorded
  bool resolve_doubtful = true;         // RenderOptions::gpu_resolve_doubtful (a test hook)
};

// A GPU device (when one was opened): the Vulkan kernels on its GPU copies. A CPU thread:
// Embree on the RAM copies, ray by ray through the recorder when there is one (the
// renderer opens no GPU then: the recorder classifies what the CPU kernels do).
std::unique_ptr<accel::Aggregate> make_aggregate(ComputeKind kind, const AggregateSources& sources);

}  // namespace rayline::engine

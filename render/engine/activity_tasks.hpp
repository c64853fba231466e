// The work of every planned activity on this machine (LocalExecutor's task factories):
//   an E-job runs on its compute device's aggregate (aggregate_factory.hpp);
//   a T-job disk->RAM loads a scene block into the BlockStore, RAM->GPU a scene block or a
//   ray queue into the GpuStore (ray queues in RAM need no work: host memory is shared);
//   the evictions the plan decided (Schedule::Eviction) run first in the activity that
//   needed the space, so what is resident mirrors the plan's copies.
// Read-ahead hints: the next disk->RAM load reads its block file while the channel still
// builds the previous block's BVH (BlockStore::read_ahead).
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "render/accel/aggregate.hpp"
#include "render/engine/local_executor.hpp"
#include "render/engine/render_workload.hpp"
#include "render/store/block_store.hpp"
#include "render/store/gpu_store.hpp"
#include "sched/timeline/schedule.hpp"

namespace rayline::engine {

class ActivityTasks {
 public:
  struct Setup {
    const DeviceGraph& g;
    const Schedule& schedule;
    RenderWorkload& workload;
    const trace::TraceSettings& ts;
    const std::map<BlockId, std::uint32_t>& cell_of;  // scene block -> its cell
    MemId ram = kNone, gmem = kNone;                   // host memory; the GPU's memory (kNone: none)
    BlockStore& store;
    GpuStore* gpu = nullptr;
    bool read_ahead = true;
  };
  // `aggregates[d]`: the aggregate of compute device d.
  ActivityTasks(Setup s, std::vector<std::unique_ptr<accel::Aggregate>> aggregates);

  // Called on the loop's thread at dispatch (LocalExecutor::TaskFactory).
  LocalExecutor::Task task(ActivityId id, const Activity& a);
  LocalExecutor::Task hint(ActivityId id, const Activity& a) const;

 private:
  // Evictions the plan decided for one activity: scene blocks leave RAM or GPU memory, ray
  // queues leave GPU memory.
  struct Victims {
    std::vector<std::uint32_t> ram_cells, gpu_cells;
    std::vector<BlockId> gpu_queues;
  };
  Victims victims_of(ActivityId id);
  void evict(const Victims& v) const;  // on the activity's thread, before its work
  LocalExecutor::Task exec_task(const Activity& a, Victims evict);
  LocalExecutor::Task gpu_transfer_task(const Activity& a, Victims evict);

  Setup s_;
  std::vector<std::unique_ptr<accel::Aggregate>> aggregates_;
  std::size_t ev_cursor_ = 0;                  // evictions of the schedule sorted into victims_
  std::map<ActivityId, Victims> victims_;
};

}  // namespace rayline::engine

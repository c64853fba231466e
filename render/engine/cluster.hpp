// The seam between render() and a distributed engine (render/mpi/README.md): rank 0 runs
// render() as on one machine, over a DCG of one node per rank joined by a LAN, with an
// executor whose lanes for other ranks' devices and channels carry each activity to its
// rank. Only this interface is seen here; MPI stays in render/mpi.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "render/engine/local_executor.hpp"
#include "render/engine/workstation.hpp"

namespace rayline::trace {
struct TraceSettings;
class Film;
}  // namespace rayline::trace

namespace rayline::engine {

class BlockStore;
class GpuStore;
class RenderWorkload;
struct RenderResult;

// What every rank needs to trace the frame (sent to the others before the run).
struct ClusterFrame {
  std::string scene, blocks_dir;
  int width = 0, height = 0, spp = 0, max_depth = 0, threads = 1, build_threads = 1, quality = 1;
  std::uint64_t seed = 1;
  bool skip_empty = true;
  bool continue_in_cell = true;
  std::vector<std::uint64_t> footprint;  // bytes the plan charges per block
  std::string gpu;                       // the Vulkan device every node opens (rank 0's name); "" = none
};

// What one rank did in a distributed render (metrics "ranks").
struct RankStats {
  std::string host;
  std::uint64_t execs = 0, loads = 0, evictions = 0, bytes_read = 0;
  std::uint64_t scene_in = 0, scene_out = 0;    // scene blocks received from / sent to other ranks' RAM
  std::uint64_t queues_in = 0, queues_out = 0;  // ray queues likewise
  std::uint64_t messages_sent = 0, bytes_sent = 0;
  std::uint64_t gpu_jobs = 0;  // E-jobs its GPU ran
  bool lost = false;  // stopped answering during the render (its figures are unknown)
  // Its E-jobs: seconds traced there, and seconds from dispatch to outputs as rank 0 saw
  // them (the difference: messages, the outputs' way back, waits for a core).
  double exec_traced_seconds = 0, exec_seen_seconds = 0;
};

// Rank 0's side of the run, for the executor.
struct ClusterWork {
  const DeviceGraph& g;
  const Schedule& schedule;
  RenderWorkload& workload;
  const trace::TraceSettings& ts;  // rank 0's (its film is the image)
  const std::map<BlockId, std::uint32_t>& cell_of;
  BlockStore& store;               // rank 0's RAM
  bool read_ahead = true;
  GpuStore* gpu = nullptr;         // rank 0's GPU memory, if the nodes have a GPU
};

class Cluster {
 public:
  virtual ~Cluster() = default;
  virtual int ranks() const = 0;
  // Compute threads per rank when --threads is not given: the machine's hardware threads
  // shared among the ranks it runs.
  virtual int default_threads() const = 0;
  // The LAN measured between the ranks (ping-pong at startup).
  virtual LanModel lan() const = 0;
  // Hands the frame to the other ranks: each loads the scene and opens the blocks.
  virtual void start(const ClusterFrame& f) = 0;
  virtual std::unique_ptr<LocalExecutor> executor(const ClusterWork& w) = 0;
  // After the run: stops the other ranks and adds what they measured to `res` (metrics).
  virtual void finish(RenderResult& res) = 0;
  // Ranks found lost since the last call (they stopped answering; `mpirun --enable-recovery`
  // kept the others running): the renderer takes their devices and data out of the plan.
  virtual std::vector<int> take_lost() = 0;
};

}  // namespace rayline::engine

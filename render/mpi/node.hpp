// One rank's own devices in a distributed render (render/mpi/README.md): its RAM (a
// BlockStore under its budget, and the ray queues sent to it), its CPU threads' aggregates,
// and the handlers of the messages that make them work: Load, Exec, Send, Data, Evict.
// Long work runs on a thread of its own, so the receiver thread keeps matching messages;
// each ends with a Done message to the master (or, on the master, a local completion).
#pragma once
#include <atomic>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "render/accel/aggregate.hpp"
#include "render/engine/cluster.hpp"
#include "render/integrator/path_kernels.hpp"
#include "render/mpi/comm.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"
#include "render/store/block_store.hpp"
#include "render/store/gpu_store.hpp"
#include "render/vulkan/vulkan_device.hpp"

namespace rayline::mpi {

class Reader;

// The frame as the Setup message carries it.
Buffer encode_frame(const engine::ClusterFrame& f);
engine::ClusterFrame decode_frame(const Buffer& b);

class Node {
 public:
  // On rank 0 `store` is the renderer's own (its threads trace through ClusterTasks);
  // elsewhere the node loads the scene, opens the blocks and the GPU named by the frame
  // itself (store == nullptr). Its compute devices are, in order, `threads` CPU threads and
  // the GPU, as the node type of engine::cluster_json.
  Node(Comm& comm, const engine::ClusterFrame& f, engine::BlockStore* store = nullptr, engine::GpuStore* gpu = nullptr);
  ~Node();
  // On the receiver thread. Returns false for a message that is not the node's.
  bool handle(int source, Buffer message);
  // Rank 0: a Data message's arrival ends the T-job here (activity, ok, why).
  std::function<void(int, bool, const std::string&)> on_local_done;
  engine::BlockStore& store() { return *store_; }
  // The rays of a ray queue block this rank holds (a Send from here); empty when none.
  std::vector<trace::RayRecord> queue(std::int32_t block);
  // Waits for the work in flight; its threads are joined.
  void drain();

 private:
  void spawn(std::int32_t activity, std::function<void()> work);
  void done(std::int32_t activity, bool ok, const std::string& why, Buffer* payload = nullptr);
  void evict(Reader& r);
  void load(const Buffer& m);
  void exec(const Buffer& m);
  void send(const Buffer& m);
  void data(const Buffer& m);
  void upload(const Buffer& m);

  Comm& comm_;
  engine::ClusterFrame frame_;
  scene::Scene scene_;
  partition::BlockIndex index_;
  std::unique_ptr<engine::BlockStore> own_store_;
  engine::BlockStore* store_;
  std::unique_ptr<gpu::GpuContext> gpu_ctx_;  // the node's GPU (frame.gpu), if any
  std::unique_ptr<engine::GpuStore> own_gpu_;
  engine::GpuStore* gpu_ = nullptr;            // own_gpu_, or rank 0's
  trace::TraceSettings ts_;
  std::vector<std::unique_ptr<accel::Aggregate>> aggregates_;  // per local CPU thread
  std::mutex mu_;
  std::map<std::int32_t, std::vector<trace::RayRecord>> queues_;
  std::vector<std::future<void>> work_;

 public:
  // What this rank did (the Stats reply).
  std::atomic<std::uint64_t> execs{0}, scene_in{0}, scene_out{0}, queues_in{0}, queues_out{0};
  std::uint64_t gpu_jobs() const { return gpu_ ? gpu_->stats().gpu_jobs : 0; }
};

}  // namespace rayline::mpi

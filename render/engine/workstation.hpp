// The device connectivity graph of this machine (Sec. 3.2) for the real renderer: the
// block store (disk), host RAM with the memory budget as its capacity, one compute device
// per worker thread (a CPU hardware thread, as in the paper), and the disk→RAM channel
// whose T-jobs read a block and build its BVH. With a Vulkan device the graph
// gains, as in the paper's Fig. 2, a GPU compute device on its own memory device (capacity
// = the GPU memory budget) and a full-duplex PCIe channel RAM<->GPU whose T-jobs upload
// blocks (+ their GPU BVH) and ray queues. Timing comes from `rayline calibrate`
// (a platform file) or from the defaults below, which only seed the first plans: the
// runtime loop re-projects every plan from measured times.
#pragma once
#include <string>
#include <vector>

#include "sched/core/device_graph.hpp"

namespace rayline::engine {

// One GPU of the workstation (names: compute "gpu0", memory "gpu0mem", channel "pcie0").
struct GpuModel {
  Bytes memory = Bytes(1) << 30;       // the GPU memory budget
  Time pcie_latency = 50e-6;           // per T-job: submit + fence
  double pcie_bandwidth = 4e9;         // bytes/s (block upload includes the CPU BVH build)
  Time intersect_setup = 200e-6;       // RayIntersect: dispatch + hit download + host shading
  double intersect_rate = 1.0 / 256e6; // s per RayQueue byte (4 M rays/s, host shading bound)
  Time shadow_setup = 200e-6;
  double shadow_rate = 1.0 / 512e6;
};

struct WorkstationModel {
  int threads = 2;
  Bytes ram_capacity = Bytes(1) << 40;
  Bytes disk_capacity = Bytes(1) << 50;
  int loaders = 1;                     // disk->RAM channels: loads (read + BVH build) in flight at once
  Time disk_latency = 1e-3;            // s per block: open, first read, BVH build setup
  double disk_bandwidth = 150e6;       // footprint bytes/s: read + BVH build
  double disk_cpu_contention = 0;      // Channel::cpu_contention: the build shares the cores
  double disk_exec_contention = 0;     // Channel::exec_contention: ... and slows the threads
  Time intersect_setup = 20e-6;        // RayIntersect, per job
  double intersect_rate = 1.0 / 64e6;  // s per RayQueue byte (1 M rays/s per thread, 64 B rays)
  Time shadow_setup = 20e-6;
  double shadow_rate = 1.0 / 128e6;    // s per ShadowRayQueue byte
  std::vector<GpuModel> gpus;          // Vulkan compute devices (0 or more)
  ControlLoop loop;                    // the loop's latency after a finished E-job (fitted by calibrate)
};

// Names used by the renderer: memories "disk" and "ram" (+ "gpu<i>mem"), job types
// "RayIntersect" and "ShadowIntersect".
// `platform` names where the model came from ("auto" or a file: error messages).
DeviceGraph make_workstation(const WorkstationModel& m, const std::string& platform = "auto");

// A platform file (as written by `rayline calibrate`) read back into a model; checks that it
// describes one machine the renderer can drive: a disk and a host memory device, a
// disk→RAM channel, CPU compute devices on RAM running both job types, and optionally GPU
// compute devices on GPU memory linked to RAM both ways. The caller applies its overrides
// (threads, capacities, GPUs) and builds the graph with make_workstation.
WorkstationModel load_workstation_model(const std::string& path);
// "auto" (or "") = the defaults above, else load_workstation_model(platform).
WorkstationModel workstation_model(const std::string& platform);

// One GPU of `memory` bytes (its calibrated timing kept, else the defaults), or none when
// `memory` is 0.
void set_gpu(WorkstationModel& m, Bytes memory);

// The platform JSON of a model (what `rayline calibrate` writes).
std::string workstation_json(const WorkstationModel& m, const std::string& description);

// The LAN between the ranks of a distributed render (render/mpi/README.md): one switched
// network, every rank's NIC on its RAM, full duplex.
struct LanModel {
  Time latency = 100e-6;
  double bandwidth = 125e6;  // bytes/s (1 Gb/s)
  std::vector<double> nic;   // per node, its NIC's bytes/s (empty: `bandwidth` for all)
};
// The LAN channel as the plan sees it: a scene block crosses the network as triangle records
// and its BVH is built on arrival (Embree's BVH is not sent), so the channel's Eq. 1
// bandwidth is the network's and `m`'s disk channel (read + build, a bound on the build) in
// series: 1 / (1 / network + 1 / disk channel). Ray queues are charged the same.
LanModel lan_for_plan(LanModel network, const WorkstationModel& m);
// `nodes` identical nodes "R0", "R1", ... of model `m` on one LAN: a distributed render's DCG
// (what `rayline calibrate --distributed` writes).
std::string cluster_json(const WorkstationModel& m, int nodes, const LanModel& lan, const std::string& description);
// A platform file's first node as a model; with `nodes` (a cluster file), the node count
// and the LAN's first channel too (`lan`), every node taken as the first.
WorkstationModel load_node_model(const std::string& path, int* nodes, LanModel* lan);

}  // namespace rayline::engine

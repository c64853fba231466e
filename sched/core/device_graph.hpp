// Device connectivity graph (DCG, Sec. 3.2, Fig. 2): memory devices are vertices,
// channels are directed edges with latency and bandwidth (Eq. 1), and each compute
// device is attached to exactly one memory device.
//
// Contention (our extension of the paper's per-channel FinishTime(c), Eq. 3): every
// channel uses one or more Resources. A half-duplex medium is ONE resource used by both
// directions; a full-duplex medium is one resource per direction; a LAN channel
// X.ram -> Y.ram uses X's NIC-out and Y's NIC-in resources, so every transfer leaving
// X over the LAN contends for X's port. The planner keeps one timeline per resource and
// a T-job occupies all resources of its channel for its whole interval.
#pragma once
#include <string>
#include <string_view>
#include <vector>

#include "sched/core/timing_model.hpp"
#include "sched/core/types.hpp"

namespace rayline {

enum class MemoryKind : std::uint8_t { Disk, Host, Gpu };
enum class ComputeKind : std::uint8_t { Cpu, Gpu };
enum class Duplex : std::uint8_t { Half, Full };

std::string_view to_string(MemoryKind k);
std::string_view to_string(ComputeKind k);

struct Node {
  std::string name;
  std::vector<MemId> memories;
  std::vector<DeviceId> computes;
};

struct MemoryDevice {
  std::string name;  // qualified: "A0.ram", "A0.gpu0.mem"
  MemoryKind kind = MemoryKind::Host;
  Bytes capacity = 0;
  NodeId node = kNone;
};

struct ComputeDevice {
  std::string name;   // qualified: "A0.cpu3", "A0.gpu0"
  std::string model;  // the platform entry it came from ("cpu", "gpu0"): identical hw threads share it
  ComputeKind kind = ComputeKind::Cpu;
  MemId memory = kNone;
  NodeId node = kNone;
};

struct Resource {
  std::string name;        // "A0.sata", "A0.nic.out", "lan1g.switch"
  double bandwidth = 0;    // bytes/s, for the simulator's link and utilisation metrics
};

struct Channel {
  std::string name;   // "A0.sata", "A0.pcie0.up", "lan:A0->A1"
  std::string kind;   // free text from the platform file: "sata", "pcie", "lan"
  MemId from = kNone, to = kNone;
  Time latency = 0;        // T_LAT, seconds
  double bandwidth = 0;    // T_BW, bytes/s
  std::vector<ResourceId> resources;
  std::int32_t network = kNone;  // the Network it joins two members of; kNone: a point-to-point channel
  // Work its T-jobs do on the CPU of the node they go to (a load's BVH build) competes with
  // the E-jobs of its CPU threads. While k of the node's n CPU threads run E-jobs, its
  // T-jobs move their bytes at bandwidth / (1 + cpu_contention x k / n); while m of its
  // T-jobs run, the node's CPU threads run E-jobs 1 + exec_contention x m times slower.
  // 0: no competition. The simulator only; the plan's Eq. 1 and Eq. 2 ignore it
  // (docs/validation.md, "Loads that share the cores").
  double cpu_contention = 0, exec_contention = 0;
};

// A switched network as the platform file describes it, kept beside the channels it
// expands to so that a simulator can build it once (a switch, racks, a backbone) instead
// of one route per ordered pair of members. Each channel of the network (Channel::network)
// uses the sender's NIC-out, then, between racks, the sender's rack uplink, the backbone
// and the receiver's rack downlink, then the receiver's NIC-in; without racks, the backbone
// (if any) between the two NICs.
struct NetworkMember {
  NodeId node = kNone;
  MemId memory = kNone;         // the memory device its NIC attaches to
  ResourceId out = kNone, in = kNone;  // NIC resources (the same one when half duplex)
  std::int32_t rack = kNone;    // index into Network::racks; kNone without racks
};

struct Rack {
  std::string name;
  ResourceId up = kNone, down = kNone;  // uplink to the backbone (the same one when half duplex)
};

struct Network {
  std::string name;
  std::vector<NetworkMember> members;
  std::vector<Rack> racks;
  ResourceId backbone = kNone;  // shared by all traffic between racks (all traffic without racks)

  // Whether a transfer from members[a] to members[b] crosses the backbone.
  bool crosses_backbone(std::size_t a, std::size_t b) const {
    return backbone != kNone && (racks.empty() || members[a].rack != members[b].rack);
  }
  // The resources that transfer occupies, in route order: NIC-out, [rack uplink,]
  // [backbone,] [rack downlink,] NIC-in.
  std::vector<ResourceId> route(std::size_t a, std::size_t b) const;
};

// The master's control loop (docs/validation.md): after an E-job finishes, the loop takes
// time to absorb the event, let the workload make jobs, plan them and wake the device that
// runs the next one: per_job + per_exec_second x the finished job's own duration (its rays
// are staged by the loop). An engine that runs the loop in zero time (the simulator) holds
// what the loop dispatches in answer to a finished job back by this much. 0: no model.
struct ControlLoop {
  Time per_job = 0;
  double per_exec_second = 0;
  // A T-job dispatched before it could start (waiting for the E-job whose block it evicts,
  // or for another dependency) starts this much after it could: the loader thread, woken
  // on cores the compute threads keep busy. The simulator applies it; rayline calibrate
  // fits it as the mean of such waits in its render (docs/validation.md).
  Time wake = 0;
  // Before its first plan the loop makes the first wave of camera rays (a render of more
  // than one block: a wave of up to the paths-in-flight cap, each ray walked to its first
  // cell and queued). What that plan dispatches starts no earlier than the wave's rays x
  // this. Later waves are made in answer to finished jobs, inside `latency`.
  Time per_camera_ray = 0;
  // An E-job dispatched before its thread's previous job ended, its inputs in place, starts
  // this much after that job's end: the worker thread reports the end and takes the next
  // job from the loop's hands (a hand-over between threads).
  Time pickup = 0;
  bool modelled() const { return per_job > 0 || per_exec_second > 0; }
  Time latency(Time exec_seconds) const { return per_job + per_exec_second * exec_seconds; }
};

class DeviceGraph {
 public:
  std::string name;
  std::string source_file;  // for error messages
  std::vector<Node> nodes;
  std::vector<MemoryDevice> memories;
  std::vector<ComputeDevice> computes;
  std::vector<Resource> resources;
  std::vector<Channel> channels;
  std::vector<Network> networks;
  std::vector<std::string> job_types;  // JobTypeId -> name
  TimingModel timing;                  // per compute device x job type (Eq. 2)
  ControlLoop loop;                    // the master's control loop (platform "control_loop")
  MemId client_memory = kNone;         // where path-tracing clients keep their framebuffers (platform "clients")

  // Build adjacency and check structural invariants; throws InputError naming the field.
  void finalize();

  const std::vector<ChannelId>& out_channels(MemId m) const { return out_[m]; }
  const std::vector<ChannelId>& in_channels(MemId m) const { return in_[m]; }
  const std::vector<DeviceId>& computes_on(MemId m) const { return attached_[m]; }

  // Eq. 1: T_TRANS(c, w) = T_LAT(c) + |w| / T_BW(c).
  Time transfer_time(ChannelId c, Bytes bytes) const {
    const Channel& ch = channels[c];
    return ch.latency + static_cast<double>(bytes) / ch.bandwidth;
  }

  JobTypeId job_type(std::string_view name) const;  // kNone when unknown
  JobTypeId add_job_type(std::string_view name);    // idempotent
  MemId find_memory(std::string_view name) const;   // kNone when unknown
  DeviceId find_compute(std::string_view name) const;
  NodeId find_node(std::string_view name) const;

  // Shortest uncontended T_TRANS for a block of `bytes` from any of `sources` to every
  // memory device (plain Dijkstra on Eq. 1 weights); kNever where unreachable.
  std::vector<Time> shortest_fetch_times(const std::vector<MemId>& sources, Bytes bytes) const;

 private:
  std::vector<std::vector<ChannelId>> out_, in_;
  std::vector<std::vector<DeviceId>> attached_;
};

}  // namespace rayline

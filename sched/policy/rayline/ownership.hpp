// Block ownership (Rayline's policy, docs/rayline-policy.md, rule 1): which node keeps and
// intersects each scene block, so that rays move to data instead of data to rays.
//
//   * replica groups: nodes are split into groups that each hold the whole scene in their
//     host memories; every group renders its own share of the image (rays never leave
//     their group);
//   * a node whose memories (host RAM and GPU memory together) hold `replicate_fraction`
//     of the scene is a group of its own: the scene is replicated and rays stay on their
//     node (what does not fit is streamed from its disk);
//   * the other nodes split the scene within their groups: each owns a run of consecutive
//     blocks (a median-split partition numbers its blocks along the split tree, so a run
//     is a compact region and most rays leaving a block stay on the node), in proportion
//     to the node's weight, never more than `host_share` of its host memory plus
//     `gpu_share` of its GPU memories. A node's
//     weight is its peak ray throughput, capped (when the scene is split) at `lan_reuse`
//     times its LAN bandwidth: the rays a node processes arrive over its NIC in part, so
//     a node on a slow link owns and generates little, and nothing at all when the cap
//     leaves it less than `min_lan_fraction` of its throughput (its NIC would be the
//     bottleneck of every ray it touches).
#pragma once
#include <vector>

#include "sched/core/device_graph.hpp"

namespace rayline {

struct OwnershipOptions {
  double host_share = 0.75;  // of a node's host memory for owned blocks (the rest: ray queues)
  double gpu_share = 0.75;   // of its GPU memories
  // Ray bytes a node processes per byte its NIC brings in (rays cross to an owner once,
  // then mostly visit its neighbouring blocks there).
  double lan_reuse = 4.0;
  double min_lan_fraction = 0.1;
  double replicate_fraction = 0.9;
};

struct Ownership {
  std::vector<int> group_of_node;          // per node; -1: a node without compute devices
  std::vector<std::vector<NodeId>> groups;  // nodes of each group
  // owner[group][i]: the node of that group owning scene block i (the i-th block passed in).
  std::vector<std::vector<NodeId>> owner;
  std::vector<MemId> host_of_node;  // the host memory a node's CPU threads work from (kNone: none)
  std::vector<double> weight;       // per node: its share of the work (ray bytes/s; 0: none)
  bool replicated() const;          // every group is one node
};

// Per node: the bandwidth (bytes/s) of its links to other nodes, summed over networks
// (min of NIC in and out) plus its fastest point-to-point channel to another node.
std::vector<double> node_lan_bandwidth(const DeviceGraph& g);

// `block_bytes` in block order (consecutive blocks are neighbours in space).
Ownership plan_ownership(const DeviceGraph& g, const std::vector<Bytes>& block_bytes, OwnershipOptions opt = {});

// Warm start under ownership: each owner's host memory takes its blocks in block order, then
// its GPU memories take first the blocks the host could not hold, then the others, while
// they fit in `share` of each capacity. Empty when the scene
// is replicated (every cache then converges to the blocks used most: the default warm start).
std::vector<std::vector<MemId>> ownership_warm_placement(const Ownership& o, const DeviceGraph& g,
                                                         const std::vector<Bytes>& block_bytes, double host_share = 0.75,
                                                         double gpu_share = 0.75);

}  // namespace rayline

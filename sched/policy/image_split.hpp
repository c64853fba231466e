// Image-space splits over nodes (Budge 2009's decomposition, and Rayline's choice of where
// a frame's rays are generated): a fixed, well-mixed point in [0, 1) per job id, like a
// tile's place in the image, picks a node with probability proportional to its weight.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "sched/core/device_graph.hpp"

namespace rayline {

// Per node: the summed peak RayIntersect throughput of its compute devices on ray queues
// (bytes/s, 1 / rate); 0 for a node without one (or when the platform has no RayIntersect).
std::vector<double> node_ray_throughput(const DeviceGraph& g);

// The index i with weights[i] > 0 that `key` falls on, each with probability
// weights[i] / sum; kNone when every weight is 0.
int weighted_pick(std::uint64_t key, const std::vector<double>& weights);

}  // namespace rayline

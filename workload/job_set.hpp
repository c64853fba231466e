// A static job set: data blocks (with where they are at t = 0) and E-jobs. Read from JSON
// (`rayline plan --jobs F`, schema in docs/job-sets.md) or generated synthetically.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "sched/core/device_graph.hpp"
#include "sched/core/job_pool.hpp"

namespace rayline {

struct JobSet {
  JobPool pool;
  std::vector<std::pair<BlockId, MemId>> initial;  // copies present at t = 0 (origins)
};

// Throws InputError(file, field, ...) on any problem: invalid JSON, unknown keys, unknown
// block / memory device / job type / data kind, malformed sizes, outputs that are also
// initially placed, a block produced twice, `after` cycles, a job type no device can run.
JobSet load_job_set(const std::string& path, const DeviceGraph& g);
JobSet parse_job_set(const std::string& json_text, const std::string& file_label, const DeviceGraph& g);

// Synthetic ray-batching snapshot (Sec. 6 scale): `blocks` SceneData blocks of about
// scene_bytes/blocks each, a full copy on every disk (Sec. 6.1: "each node has a full copy
// of the model dataset on its HDD"); `jobs` RayIntersect jobs, each with its own RayQueue
// of 10 k - 500 k rays x 64 B in a random node's host memory; block popularity is skewed
// (Zipf, s = 1) as rays concentrate on visible blocks. Queues fill at most half of each host
// memory, so a small platform gets fewer than `jobs` jobs. Deterministic for a seed.
JobSet synthetic_ray_batching(const DeviceGraph& g, int blocks, int jobs, std::uint64_t seed,
                              Bytes scene_bytes = Bytes(26.5 * 1024 * 1024 * 1024.0));

}  // namespace rayline

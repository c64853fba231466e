// Per queued job, what its inputs say, kept up to date as merges append inputs (Sec. 5.1: a
// queued job of a long run can hold thousands of merged ray queues): its scene blocks, the
// bytes of its consumed (real) queues, which never change, and its other inputs, whose
// bytes can (a prediction's placeholder is rescaled), summed at each use. For the
// policies that rank jobs by their rays (Budge 2009, Rayline's).
#pragma once
#include <vector>

#include "sched/core/job_pool.hpp"

namespace rayline {

class InputSummaries {
 public:
  struct Summary {
    std::size_t seen = 0;  // inputs read so far (a job's inputs are only ever appended to)
    Bytes fixed_rays = 0;
    std::vector<BlockId> scene, live;
  };
  const Summary& of(JobId j, const JobPool& pool);
  // Bytes of every non-scene input now.
  Bytes rays(JobId j, const JobPool& pool) {
    const Summary& in = of(j, pool);
    Bytes r = in.fixed_rays;
    for (BlockId b : in.live) r += pool.block(b).bytes;
    return r;
  }
  void clear() { s_.clear(); }

 private:
  std::vector<Summary> s_;
};

}  // namespace rayline

// The GMB planning-speed benchmark instance, shared by bench_sched_gmb (wall time)
// and plan_instructions (instruction counts) so both measure the same thing: 129 scene
// blocks on every node's disk and 1 000 queued RayIntersect jobs (synthetic_ray_batching,
// seed 42), each plan on a fresh copy of the job set and a fresh Schedule.
#pragma once
#include <memory>

#include "workload/job_set.hpp"
#include "sched/timeline/schedule.hpp"

namespace rayline::bench {

inline JobSet gmb_bench_jobs(const DeviceGraph& g, int blocks = 129, int jobs = 1000) {
  return synthetic_ray_batching(g, blocks, jobs, 42);
}

// A fresh copy of `base` and a Schedule holding its initial copies (the untimed set-up of
// one plan).
struct FreshPlan {
  std::unique_ptr<JobSet> set;
  std::unique_ptr<Schedule> schedule;
};
inline FreshPlan fresh_plan(const DeviceGraph& g, const JobSet& base) {
  FreshPlan p{std::make_unique<JobSet>(base), nullptr};
  p.schedule = std::make_unique<Schedule>(g, p.set->pool);
  for (auto [b, m] : p.set->initial) p.schedule->put_initial(b, m);
  return p;
}

}  // namespace rayline::bench

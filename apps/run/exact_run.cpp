#include "apps/run/exact_run.hpp"

#include "sched/io/platform_loader.hpp"
#include "sched/policy/scheduler_factory.hpp"

namespace rayline::cli {

ExactRun::ExactRun(const ExactRunOptions& opt)
    : graph_(load_platform(opt.platform_file)),
      set_(opt.jobs_file.empty() ? synthetic_ray_batching(graph_, opt.synthetic_blocks, opt.synthetic_jobs, opt.seed)
                                 : load_job_set(opt.jobs_file, graph_)),
      schedule_(graph_, set_.pool),
      scheduler_(make_scheduler(opt.scheduler)),
      executor_(schedule_) {
  for (auto [b, m] : set_.initial) schedule_.put_initial(b, m);
}

RunStats ExactRun::run() {
  StaticWorkload workload;
  RuntimeLoop loop(*scheduler_, executor_, workload, set_.pool, schedule_);
  return loop.run();
}

}  // namespace rayline::cli

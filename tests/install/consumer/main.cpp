// Plans a small job set with GMB on an installed platform file, through the installed
// Rayline::sched package only, runs the plan exactly as predicted and prints the makespan.
//   consumer [PLATFORM.json]   (default: the installed paper-2A platform)
#include <cstdio>
#include <exception>
#include <string>

#include "common/error.hpp"
#include "sched/core/device_graph.hpp"
#include "sched/core/job_pool.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "sched/runtime/workload.hpp"
#include "sched/timeline/schedule.hpp"

namespace {

// The first disk of the platform: where every block starts.
rayline::MemId first_disk(const rayline::DeviceGraph& g) {
  for (std::size_t m = 0; m < g.memories.size(); ++m)
    if (g.memories[m].kind == rayline::MemoryKind::Disk) return static_cast<rayline::MemId>(m);
  throw rayline::InputError(g.source_file, "memory", "no disk to hold the blocks");
}

// Eight 64 MB blocks on the first disk, and two "Compute" jobs reading each of them.
void add_jobs(const rayline::DeviceGraph& g, rayline::JobPool& pool, rayline::Schedule& schedule) {
  const rayline::JobTypeId compute = g.job_type("Compute");
  if (compute == rayline::kNone) throw rayline::InputError(g.source_file, "job_types", "no Compute job type");
  for (int b = 0; b < 8; ++b) {
    rayline::DataBlock block;
    block.name = "block" + std::to_string(b);
    block.bytes = 64'000'000;
    const rayline::BlockId id = pool.add_block(block);
    schedule.put_initial(id, first_disk(g));
    for (int j = 0; j < 2; ++j) {
      rayline::Job job;
      job.name = block.name + ".job" + std::to_string(j);
      job.type = compute;
      job.inputs = {id};
      job.work = 1;
      pool.add_job(job);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::string platform = argc > 1 ? argv[1] : std::string(RAYLINE_DATA_DIR) + "/platforms/paper-2A.json";
  try {
    const rayline::DeviceGraph g = rayline::load_platform(platform);
    rayline::JobPool pool;
    rayline::Schedule schedule(g, pool);
    add_jobs(g, pool, schedule);
    rayline::GmbScheduler gmb(rayline::GmbOptions{});
    rayline::ExactExecutor executor(schedule);
    rayline::StaticWorkload workload;
    rayline::RuntimeLoop loop(gmb, executor, workload, pool, schedule);
    const rayline::RunStats stats = loop.run();
    std::printf("platform %s: %zu jobs, %llu E-jobs and %llu T-jobs, makespan %.6f s%s\n", g.name.c_str(),
                pool.job_count(), static_cast<unsigned long long>(stats.execs),
                static_cast<unsigned long long>(stats.transfers), stats.makespan, stats.stalled ? " (stalled)" : "");
    return stats.stalled || stats.execs != pool.job_count() ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 2;
  }
}

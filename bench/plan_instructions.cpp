// Deterministic cost of GMB planning: the bench instance of bench_sched_gmb (129
// scene blocks, 1 000 queued RayIntersect jobs) planned N times by one kept GmbScheduler,
// each on a fresh Schedule, after one warm-up plan; under valgrind's callgrind, collection is
// toggled around plan() alone, so "instructions / N" is the instruction count of one warm
// plan, free of this shared machine's timing noise. --cold builds a new scheduler for every
// plan instead (bench_sched_gmb's cold cases; the construction is counted too). Run it
// through scripts/count_plan_instructions.sh; without valgrind it just plans.
#include <valgrind/callgrind.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>

#include "bench/gmb_bench_instance.hpp"
#include "common/error.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/io/platform_loader.hpp"

using namespace rayline;

int main(int argc, char** argv) {
  const bool cold = argc > 1 && std::string(argv[1]) == "--cold";
  if (cold) {
    --argc;
    ++argv;
  }
  const std::string arg1 = argc > 1 ? argv[1] : "";
  if (arg1 == "--help" || arg1 == "-h" || argc > 4) {
    std::printf("usage: plan_instructions [--cold] [PLATFORM.json] [HORIZON_S] [PLANS]\n"
                "  defaults: %s/paper-cluster.json 2 10\n"
                "  Plans the bench_sched_gmb instance PLANS times with one kept scheduler (after one\n"
                "  warm-up plan), collecting callgrind events around plan() only. --cold: a new\n"
                "  scheduler for every plan, its construction and plan() counted.\n",
                RAYLINE_PLATFORMS);
    return argc > 4 ? 2 : 0;
  }
  const std::string platform = argc > 1 ? arg1 : std::string(RAYLINE_PLATFORMS) + "/paper-cluster.json";
  char* end = nullptr;
  const double horizon = argc > 2 ? std::strtod(argv[2], &end) : 2.0;
  if (argc > 2 && (*end != '\0' || !(horizon > 0))) {
    std::fprintf(stderr, "plan_instructions: HORIZON_S must be a positive number of seconds, got '%s'\n", argv[2]);
    return 2;
  }
  const long plans = argc > 3 ? std::strtol(argv[3], &end, 10) : 10;
  if (argc > 3 && (*end != '\0' || plans < 1)) {
    std::fprintf(stderr, "plan_instructions: PLANS must be a positive integer, got '%s'\n", argv[3]);
    return 2;
  }
  try {
    const DeviceGraph g = load_platform(platform);
    const JobSet base = bench::gmb_bench_jobs(g);
    GmbScheduler kept(GmbOptions{.horizon = horizon});
    double placements = 0;
    for (long i = 0; i <= plans; ++i) {  // plan 0 warms the kept scheduler up
      auto [set, s] = bench::fresh_plan(g, base);
      if (i > 0) CALLGRIND_TOGGLE_COLLECT;
      std::unique_ptr<GmbScheduler> fresh = cold ? std::make_unique<GmbScheduler>(kept.options()) : nullptr;
      const PlanStats st = (cold ? *fresh : kept).plan(0, set->pool, *s);
      if (i > 0) CALLGRIND_TOGGLE_COLLECT;
      fresh.reset();  // (its teardown is not counted)
      if (i > 0) placements += st.execs + st.transfers;
    }
    std::printf("plans %ld\nplacements/plan %.1f\n", plans, placements / static_cast<double>(plans));
  } catch (const InputError& e) {
    std::fprintf(stderr, "plan_instructions: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "plan_instructions: %s\n", e.what());
    return 1;
  }
  return 0;
}

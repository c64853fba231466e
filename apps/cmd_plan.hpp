// `rayline plan`: plan a static job set on a platform (GMB unless --scheduler names
// another of the factory's schedulers), print makespan and per-device utilisation,
// optionally write the timelines as Chrome trace JSON and a per-job CSV.
#pragma once
#include <cstdint>
#include <string>

namespace rayline::cli {

struct PlanOptions {
  std::string platform;     // empty: platforms/paper-cluster.json next to the binary's source tree
  std::string jobs;         // empty: a synthetic job set (see --synthetic-*)
  std::string scheduler = "gmb";
  std::string horizon = "2s";
  std::string aging = "auto";  // GMB (Sec. 4.3): auto, adaptive, off, or a duration
  std::string trace;        // Chrome trace JSON output path (optional)
  std::string jobs_csv;     // per-job CSV output path (optional)
  int synthetic_blocks = 129;
  int synthetic_jobs = 1000;
  std::uint64_t seed = 1;
  bool quiet = false;
};
int run_plan(const PlanOptions& opt);

}  // namespace rayline::cli

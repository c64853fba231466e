// Job-set files (`rayline plan --jobs FILE`, `simulate --workload FILE`): workload/job_set,
// read against the default platform (platforms/paper-cluster.json), as `plan` does.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "sched/io/platform_loader.hpp"
#include "workload/job_set.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const rayline::DeviceGraph graph = rayline::load_platform(RAYLINE_PLATFORMS "/paper-cluster.json");
  const std::string path = rayline::fuzz::write_input("jobs.json", data, size);
  rayline::fuzz::expect_clean("job_set", [&] { (void)rayline::load_job_set(path, graph); });
  return 0;
}

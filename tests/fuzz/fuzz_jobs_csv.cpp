// Jobs CSV (`rayline report RUN_DIR`: RUN_DIR/jobs.csv, IMAGE.jobs.csv): apps/report/run_files'
// reader, then every chart drawn from activities (throughput, channels, queue waits, Gantt).
#include <cstddef>
#include <cstdint>

#include "apps/report/report_page.hpp"
#include "apps/report/run_files.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rayline::fuzz::write_input("jobs.csv", data, size);
  rayline::fuzz::expect_clean("jobs_csv", [&] {
    rayline::report::RunData run;
    run.jobs_file = path;
    run.activities = rayline::report::read_jobs_csv(path);
    (void)rayline::report::run_section(run, "");
  });
  return 0;
}

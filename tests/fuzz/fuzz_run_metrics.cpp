// Run metrics (`rayline report RUN_DIR`: RUN_DIR/metrics.json, IMAGE.metrics.json):
// apps/report/run_files read as a simulation's and as a render's, then charted as the
// page does (apps/report/report_page).
#include <cstddef>
#include <cstdint>

#include "apps/report/report_page.hpp"
#include "apps/report/run_files.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rayline::fuzz::write_input("metrics.json", data, size);
  for (const bool render : {false, true})
    rayline::fuzz::expect_clean("run_metrics", [&] {
      (void)rayline::report::run_section(rayline::report::read_metrics_file(path, render), "run");
    });
  return 0;
}

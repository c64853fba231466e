// `rayline report RUN_DIR`: a self-contained HTML page of a run's results (apps/report/).
#pragma once
#include <string>

namespace rayline::cli {

struct ReportOptions {
  std::string dir;  // a simulate, compare or render output folder
  std::string out;  // default: RUN_DIR/report.html
};
int run_report(const ReportOptions& opt);

}  // namespace rayline::cli

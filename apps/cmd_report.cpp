// `rayline report RUN_DIR`: read the run folder (apps/report/run_files.hpp), build the page
// (apps/report/report_page.hpp) and write it atomically; print the path written.
#include "apps/cmd_report.hpp"

#include <cstdio>
#include <filesystem>
#include <vector>

#include "apps/cli_common.hpp"
#include "apps/report/report_page.hpp"
#include "apps/report/run_files.hpp"

namespace rayline::cli {

int run_report(const ReportOptions& opt) {
  const std::string out = opt.out.empty() ? (std::filesystem::path(opt.dir) / "report.html").string() : opt.out;
  const report::RunFolder folder = report::read_run_folder(opt.dir);
  check_output_file(out, "--out", "report.html");
  std::vector<NamedPath> inputs;  // the page must not replace a file it was made from
  if (folder.compare) inputs.push_back({"RUN_DIR", folder.compare->file});
  for (const report::RunData& run : folder.runs)
    inputs.insert(inputs.end(), {{"RUN_DIR", run.metrics_file}, {"RUN_DIR", run.jobs_file}});
  check_distinct({{"--out", out}}, inputs);
  write_file_atomic(out, report::report_html(folder));
  std::printf("wrote %s\n", out.c_str());
  return kExitOk;
}

}  // namespace rayline::cli

// A run's output folder read into plain structs for `rayline report`: a simulate folder
// (metrics.json, jobs.csv), a compare folder (compare.csv and one simulate folder per
// scheduler), a client sweep (`simulate --clients N1,N2,...`: one clients-N folder per
// count) or a render's outputs (IMAGE.metrics.json, IMAGE.jobs.csv, IMAGE.png). JSON
// and CSV parsing stay in run_files.cpp; a file that is not what its run writes is an
// InputError naming the file and the field.
#pragma once
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace rayline::report {

// One row of jobs.csv: an E-job on a compute device or a T-job on a channel. Times are in
// seconds; a time the run never reached (a planned activity left at the end) is empty.
struct Activity {
  char kind = 'E';  // 'E' or 'T'
  std::string job, type, where, block, state;
  double bytes = 0;
  double planned_start = 0, planned_end = 0;
  std::optional<double> actual_start, actual_end, created;
};

// A compute device's time split (Sec. 4.2), in seconds.
struct DeviceTime {
  std::string name, kind;  // kind: cpu, gpu ... (empty when the run does not say)
  double busy_s = 0, setup_s = 0, fetching_s = 0, idle_s = 0;
};

// A channel resource (a medium channels share) or, for a render, a channel: the share of
// the run it was busy and the bytes it moved.
struct ChannelUse {
  std::string name;
  double utilisation = 0;
  double bytes = 0;
  bool lan = false;
};

// A key number of the header: a value with its unit ("rays/s", "s", "%", "B"), or text.
struct Fact {
  std::string label;
  std::optional<double> value;
  std::string unit;
  std::string text;  // when there is no value
};

// One simulate or render run.
struct RunData {
  std::string label;         // the scheduler in a compare folder, the image stem of a render
  std::string metrics_file;  // where its numbers came from
  std::string jobs_file;     // empty when the run has no jobs CSV
  bool render = false;
  std::string command, version, scheduler, platform, workload;
  std::vector<Fact> facts;                                 // key numbers, in page order
  std::vector<double> rays_per_second_series;              // per simulated second (simulate)
  double run_seconds = 0;                                  // simulated or wall time covered
  std::vector<DeviceTime> devices;
  std::vector<ChannelUse> channels;  // from metrics.json's resources[] (simulate)
  std::vector<Activity> activities;
  std::string png;  // the render's PNG preview, raw bytes (empty if none)
};

// compare.csv as written: its header and rows, cells as text.
struct CompareTable {
  std::string file;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  // The value of column `name` in row `row`; empty when there is no such column.
  std::string cell(std::size_t row, const std::string& name) const;
};

// What a folder holds: one run, a comparison of runs, a client sweep, or renders.
struct RunFolder {
  enum class Kind { simulate, compare, sweep, render };
  Kind kind = Kind::simulate;
  std::string dir;
  std::optional<CompareTable> compare;
  std::vector<RunData> runs;
};

// Reads `dir`. InputError(dir, "", ...) when it is missing, not a folder or holds no run's
// files (saying which ones were looked for); InputError(FILE, FIELD, ...) for a malformed file.
RunFolder read_run_folder(const std::string& dir);

// The pieces, for tests and for reuse.
RunData read_metrics_file(const std::string& path, bool render);
std::vector<Activity> read_jobs_csv(const std::string& path);
CompareTable read_compare_csv(const std::string& path);
// One CSV line split into cells ("a,\"b,c\"" -> a | b,c); quotes doubled inside quotes.
std::vector<std::string> split_csv_line(const std::string& line);

}  // namespace rayline::report

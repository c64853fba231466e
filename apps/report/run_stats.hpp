// What the report's charts show, computed from a run's files (apps/report/run_files.hpp):
// throughput over time, per-device and per-channel time, queue waits, and the subset of
// activities a Gantt chart can draw readably. Plain numbers, no markup.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "apps/report/run_files.hpp"

namespace rayline::report {

// A throughput curve: values[i] at x[i] (seconds), with what it counts.
struct Throughput {
  std::vector<double> x, values;
  std::string title;   // what it counts, short, for the chart's title
  std::string counts;  // e.g. "rays per simulated second (metrics.json: rays_per_second_series)"
  std::string unit;    // of values: "rays/s" or "B/s"
};
// metrics.json's rays_per_second_series when the run has one (x: the middle of each
// second), else the bytes of E-jobs finished per second of run time in up to `bins` equal
// bins (jobs.csv). Empty when neither is there.
Throughput throughput(const RunData& run, std::size_t bins = 40);

// One row of the device chart: a device, or a node's devices of one kind summed.
struct DeviceRow {
  std::string name;
  double busy_s = 0, setup_s = 0, fetching_s = 0, idle_s = 0;
};
// A row per device; with more than `max_rows` devices, a row per node and kind ("A0 cpu
// x4"), the node being the name before its first '.'.
std::vector<DeviceRow> device_rows(const std::vector<DeviceTime>& devices, std::size_t max_rows = 32);

// A channel's busy share of the run: metrics.json's resources[] when present; else, from
// jobs.csv, the union of its T-jobs' actual intervals over the run's time (run_seconds,
// or the last actual end).
std::vector<ChannelUse> channel_use(const RunData& run);

// Queue waits of E-jobs: actual_start - created, for those that started (a wait that
// overflows a double is left out).
struct WaitStats {
  std::string type;
  std::size_t count = 0;
  double p50 = 0, p95 = 0, max = 0;
};
std::vector<double> queue_waits(const std::vector<Activity>& activities);
// Per E-job type (sorted by name), then "all" last.
std::vector<WaitStats> wait_stats(const std::vector<Activity>& activities);
// The bin of `x` among `bins` bins of `width` from `lo`: values outside (and NaN) go to
// the first or last bin.
std::size_t bin_of(double x, double lo, double width, std::size_t bins);

// The value at quantile q of `v` (nearest rank, as metrics.json's percentiles).
double percentile(std::vector<double> v, double q);

// The Gantt chart's selection: the `max_rows` devices and channels with the most actual
// activity time, and of their activities the earliest ones up to `max_bars` rectangles
// (a planned and an actual one each), over the window [t0, t1] they cover.
struct GanttView {
  std::vector<std::string> rows;
  struct Bar {
    std::size_t row;
    double start, end;
    bool planned;
    const Activity* activity;
  };
  std::vector<Bar> bars;
  double t0 = 0, t1 = 0;
  std::size_t shown_activities = 0, row_activities = 0, all_activities = 0;
};
GanttView gantt_view(const std::vector<Activity>& activities, std::size_t max_rows = 10, std::size_t max_bars = 600);

}  // namespace rayline::report

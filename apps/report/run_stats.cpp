// The numbers behind the report's charts (apps/report/run_stats.hpp).
#include "apps/report/run_stats.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

namespace rayline::report {

Throughput throughput(const RunData& run, std::size_t bins) {
  Throughput t;
  if (!run.rays_per_second_series.empty()) {
    t.title = "Throughput: rays traced per simulated second";
    t.counts = "rays traced per simulated second (metrics.json: rays_per_second_series)";
    t.unit = "rays/s";
    for (std::size_t i = 0; i < run.rays_per_second_series.size(); ++i) {
      t.x.push_back(static_cast<double>(i) + 0.5);
      t.values.push_back(run.rays_per_second_series[i]);
    }
    return t;
  }
  double end = 0;
  for (const Activity& a : run.activities)
    if (a.kind == 'E' && a.actual_end) end = std::max(end, *a.actual_end);
  if (end <= 0 || bins == 0) return t;
  const double width = end / static_cast<double>(bins);
  std::vector<double> bytes(bins, 0.0);
  for (const Activity& a : run.activities)
    if (a.kind == 'E' && a.actual_end)
      bytes[bin_of(*a.actual_end, 0, width, bins)] += a.bytes;
  t.title = "Throughput: ray bytes of the E-jobs finished per second";
  t.counts = "ray-queue bytes of the E-jobs finished per second, in " + std::to_string(bins) +
             " equal time bins (jobs.csv: bytes, actual_end)";
  t.unit = "B/s";
  for (std::size_t i = 0; i < bins; ++i) {
    t.x.push_back((static_cast<double>(i) + 0.5) * width);
    t.values.push_back(bytes[i] / width);
  }
  return t;
}

std::vector<DeviceRow> device_rows(const std::vector<DeviceTime>& devices, std::size_t max_rows) {
  std::vector<DeviceRow> rows;
  if (devices.size() <= max_rows) {
    for (const DeviceTime& d : devices) rows.push_back({d.name, d.busy_s, d.setup_s, d.fetching_s, d.idle_s});
    return rows;
  }
  std::map<std::string, std::size_t> at;  // "node kind" -> row
  std::vector<std::size_t> counts;
  for (const DeviceTime& d : devices) {
    const std::string node = d.name.substr(0, d.name.find('.'));
    const std::string key = node + " " + (d.kind.empty() ? "device" : d.kind);
    const auto [it, fresh] = at.emplace(key, rows.size());
    if (fresh) {
      rows.push_back({key, 0, 0, 0, 0});
      counts.push_back(0);
    }
    DeviceRow& r = rows[it->second];
    r.busy_s += d.busy_s;
    r.setup_s += d.setup_s;
    r.fetching_s += d.fetching_s;
    r.idle_s += d.idle_s;
    ++counts[it->second];
  }
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i].name += " x" + std::to_string(counts[i]);
  return rows;
}

namespace {

// Length of the union of intervals.
double union_length(std::vector<std::pair<double, double>> v) {
  std::sort(v.begin(), v.end());
  double total = 0, start = 0, end = 0;
  bool open = false;
  for (const auto& [s, e] : v) {
    if (open && s <= end) {
      end = std::max(end, e);
      continue;
    }
    if (open) total += end - start;
    start = s;
    end = e;
    open = true;
  }
  return open ? total + (end - start) : total;
}

}  // namespace

std::vector<ChannelUse> channel_use(const RunData& run) {
  if (!run.channels.empty()) return run.channels;
  std::map<std::string, std::vector<std::pair<double, double>>> busy;
  std::map<std::string, double> bytes;
  double last = 0;
  for (const Activity& a : run.activities) {
    if (!a.actual_end) continue;
    last = std::max(last, *a.actual_end);
    if (a.kind != 'T' || !a.actual_start) continue;
    busy[a.where].emplace_back(*a.actual_start, std::max(*a.actual_start, *a.actual_end));
    bytes[a.where] += a.bytes;
  }
  const double span = run.run_seconds > 0 ? run.run_seconds : last;
  std::vector<ChannelUse> out;
  for (auto& [name, intervals] : busy)
    out.push_back({name, span > 0 ? std::min(1.0, union_length(intervals) / span) : 0.0, bytes[name], false});
  return out;
}

std::size_t bin_of(double x, double lo, double width, std::size_t bins) {
  if (bins == 0) return 0;
  const double at = width > 0 ? (x - lo) / width : 0;
  if (!(at > 0)) return 0;  // also NaN
  return at >= static_cast<double>(bins - 1) ? bins - 1 : static_cast<std::size_t>(at);
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double rank = std::min<double>(static_cast<double>(v.size() - 1), q * static_cast<double>(v.size()));
  return v[static_cast<std::size_t>(rank)];
}

std::vector<double> queue_waits(const std::vector<Activity>& activities) {
  std::vector<double> w;
  for (const Activity& a : activities)
    if (a.kind == 'E' && a.actual_start && a.created && std::isfinite(*a.actual_start - *a.created))
      w.push_back(std::max(0.0, *a.actual_start - *a.created));
  return w;
}

std::vector<WaitStats> wait_stats(const std::vector<Activity>& activities) {
  std::map<std::string, std::vector<double>> by_type;
  std::vector<double> all;
  for (const Activity& a : activities) {
    if (a.kind != 'E' || !a.actual_start || !a.created || !std::isfinite(*a.actual_start - *a.created)) continue;
    const double w = std::max(0.0, *a.actual_start - *a.created);
    by_type[a.type].push_back(w);
    all.push_back(w);
  }
  const auto stats = [](const std::string& type, const std::vector<double>& v) {
    return WaitStats{type, v.size(), percentile(v, 0.5), percentile(v, 0.95),
                     v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())};
  };
  std::vector<WaitStats> out;
  for (const auto& [type, v] : by_type) out.push_back(stats(type, v));
  if (!all.empty()) out.push_back(stats("all", all));
  return out;
}

namespace {

// `where` names ranked by actual activity time, busiest first; kind 'E' or 'T'.
std::vector<std::string> ranked_rows(const std::vector<Activity>& activities, char kind) {
  std::map<std::string, double> busy;
  for (const Activity& a : activities)
    if (a.kind == kind && a.actual_start && a.actual_end) busy[a.where] += *a.actual_end - *a.actual_start;
  std::vector<std::pair<double, std::string>> ranked;
  for (const auto& [where, t] : busy) ranked.emplace_back(-t, where);
  std::sort(ranked.begin(), ranked.end());
  std::vector<std::string> names;
  for (auto& r : ranked) names.push_back(std::move(r.second));
  return names;
}

// Busiest compute devices first, then channels: about 3/5 of the rows for devices, the
// rest for channels, a share one side does not fill going to the other.
std::vector<std::string> gantt_rows(const std::vector<Activity>& activities, std::size_t max_rows) {
  std::vector<std::string> devices = ranked_rows(activities, 'E'), channels = ranked_rows(activities, 'T');
  const std::size_t want = std::max(max_rows - std::min(channels.size(), max_rows * 2 / 5), max_rows * 3 / 5);
  devices.resize(std::min(devices.size(), want));
  channels.resize(std::min(channels.size(), max_rows - devices.size()));
  devices.insert(devices.end(), channels.begin(), channels.end());
  return devices;
}

double first_start(const Activity* a) {
  return a->actual_start ? std::min(a->planned_start, *a->actual_start) : a->planned_start;
}

// The window the bars cover, ending where the first activity left out starts (`cut_at`).
void set_window(GanttView& g, std::optional<double> cut_at) {
  if (g.bars.empty()) return;
  g.t0 = g.bars.front().start;
  g.t1 = g.bars.front().end;
  for (const GanttView::Bar& b : g.bars) {
    g.t0 = std::min(g.t0, b.start);
    g.t1 = std::max(g.t1, b.end);
  }
  if (cut_at) g.t1 = std::max(g.t0, std::min(g.t1, *cut_at));
}

}  // namespace

GanttView gantt_view(const std::vector<Activity>& activities, std::size_t max_rows, std::size_t max_bars) {
  GanttView g;
  g.all_activities = activities.size();
  g.rows = gantt_rows(activities, max_rows);
  std::map<std::string, std::size_t> row_of;
  for (std::size_t r = 0; r < g.rows.size(); ++r) row_of.emplace(g.rows[r], r);
  // The selected rows' activities by first start (planned or actual), a planned and an
  // actual bar each, until the next would pass max_bars.
  std::vector<const Activity*> chosen;
  for (const Activity& a : activities)
    if (row_of.count(a.where)) chosen.push_back(&a);
  g.row_activities = chosen.size();
  std::stable_sort(chosen.begin(), chosen.end(),
                   [](const Activity* a, const Activity* b) { return first_start(a) < first_start(b); });
  std::optional<double> cut_at;
  for (const Activity* a : chosen) {
    const bool ran = a->actual_start && a->actual_end;
    if (g.bars.size() + (ran ? 2 : 1) > max_bars) {
      cut_at = first_start(a);
      break;
    }
    const std::size_t row = row_of.at(a->where);
    g.bars.push_back({row, a->planned_start, a->planned_end, true, a});
    if (ran) g.bars.push_back({row, *a->actual_start, *a->actual_end, false, a});
    ++g.shown_activities;
  }
  set_window(g, cut_at);
  return g;
}

}  // namespace rayline::report

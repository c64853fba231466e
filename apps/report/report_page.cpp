// The HTML page of `rayline report` (apps/report/report_page.hpp).
#include "apps/report/report_page.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <sstream>

#include "apps/report/run_stats.hpp"
#include "apps/report/svg_chart.hpp"

namespace rayline::report {

namespace {

constexpr std::size_t kMaxChannelRows = 48;

// Nothing may be loaded: images only as data URIs, styles only inline.
constexpr const char* kHead = R"(<meta charset="utf-8">
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; img-src data:; style-src 'unsafe-inline'">
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1100px; color: #212529; padding: 0 1em; }
h1 { font-size: 1.5em; } h2 { border-bottom: 2px solid #dee2e6; padding-bottom: .2em; margin-top: 2em; }
table { border-collapse: collapse; margin: .5em 0 1em; font-size: .9em; }
td, th { border: 1px solid #dee2e6; padding: .2em .6em; text-align: left; vertical-align: top; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
code { background: #f1f3f5; padding: 0 .2em; word-break: break-all; }
figure { margin: 1em 0 2em; } figcaption { font-size: .85em; color: #495057; max-width: 760px; }
svg.chart { font-family: sans-serif; font-size: 11px; display: block; }
p.missing { color: #868e96; font-style: italic; }
div.wide { overflow-x: auto; } table.compare td { white-space: nowrap; }
img.render { image-rendering: pixelated; min-width: 256px; max-width: 100%; border: 1px solid #dee2e6; }
</style>
)";

std::string id_of(const std::string& prefix, const std::string& name) {
  return prefix.empty() ? name : prefix + "-" + name;
}

// A name usable in an id: letters, digits, '-' and '_' kept, the rest '_'.
std::string id_safe(const std::string& s) {
  std::string out;
  for (const char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return out.empty() ? "run" : out;
}

std::string figure(const std::string& svg, const std::string& caption) {
  return "<figure>\n" + svg + "<figcaption>" + escape_xml(caption) + "</figcaption>\n</figure>\n";
}

std::string missing(const std::string& what, const std::string& why) {
  return "<p class=\"missing\">" + escape_xml(what) + ": " + escape_xml(why) + "</p>\n";
}

std::string row(const std::string& key, const std::string& value_html) {
  return "<tr><th>" + escape_xml(key) + "</th><td>" + value_html + "</td></tr>\n";
}

std::string header_table(const RunData& run) {
  std::string h = "<table class=\"facts\">\n";
  if (!run.command.empty()) h += row("command", "<code>" + escape_xml(run.command) + "</code>");
  if (!run.version.empty()) h += row("version", escape_xml("rayline " + run.version));
  if (!run.scheduler.empty()) h += row("scheduler", escape_xml(run.scheduler));
  if (!run.platform.empty()) h += row("platform", escape_xml(run.platform));
  if (!run.workload.empty()) h += row(run.render ? "scene" : "workload", escape_xml(run.workload));
  h += row("files", "<code>" + escape_xml(run.metrics_file) + "</code>" +
                        (run.jobs_file.empty() ? "" : ", <code>" + escape_xml(run.jobs_file) + "</code>"));
  for (const Fact& f : run.facts)
    h += row(f.label, escape_xml(f.value ? format_quantity(*f.value, f.unit) : f.text));
  return h + "</table>\n";
}

std::string throughput_chart(const RunData& run, const std::string& prefix) {
  const Throughput t = throughput(run);
  if (t.values.empty()) return missing("Throughput over time", "no rays_per_second_series in metrics.json and no finished E-jobs in a jobs CSV");
  ChartFrame f{id_of(prefix, "chart-throughput"), t.title, run.render ? "run time (s)" : "simulated time (s)",
               t.unit};
  return figure(line_chart(f, t.x, {{t.unit, colour::kLine, t.values}}, t.unit), "Counts " + t.counts + ".");
}

std::string devices_chart(const RunData& run, const std::string& prefix) {
  if (run.devices.empty()) return missing("Compute devices", "metrics.json has no devices[]");
  const std::vector<DeviceRow> rows = device_rows(run.devices);
  std::vector<std::string> names;
  Series busy{"busy", colour::kBusy, {}}, setup{"setup", colour::kSetup, {}}, fetching{"fetching", colour::kFetching, {}},
      idle{"idle", colour::kIdle, {}};
  for (const DeviceRow& r : rows) {
    names.push_back(r.name);
    busy.values.push_back(r.busy_s);
    setup.values.push_back(r.setup_s);
    fetching.values.push_back(r.fetching_s);
    idle.values.push_back(r.idle_s);
  }
  ChartFrame f{id_of(prefix, "chart-devices"), "Compute devices: busy, setup, fetching, idle", "share of the device's time (%)", ""};
  f.left = 130;
  f.height = 120;
  const bool grouped = rows.size() != run.devices.size();
  return figure(stacked_hbars(f, names, {busy, setup, fetching, idle}, true, "s"),
                std::string("Each bar splits ") + (grouped ? "the summed time of a node's devices of one kind" : "a device's time") +
                    " (metrics.json devices[]): busy running E-jobs, setup (T_SETUP), fetching (idle while the next "
                    "E-job waits for its T-jobs) and true idle (Sec. 4.2).");
}

std::string channels_chart(const RunData& run, const std::string& prefix) {
  std::vector<ChannelUse> use = channel_use(run);
  if (use.empty()) return missing("Channel utilisation", "no resources[] in metrics.json and no T-jobs in a jobs CSV");
  const std::size_t all = use.size();
  if (use.size() > kMaxChannelRows) {
    std::stable_sort(use.begin(), use.end(), [](const ChannelUse& a, const ChannelUse& b) { return a.utilisation > b.utilisation; });
    use.resize(kMaxChannelRows);
  }
  std::vector<std::string> names;
  Series busy{"busy", colour::kFetching, {}}, idle{"idle", colour::kIdle, {}};
  for (const ChannelUse& c : use) {
    names.push_back(c.name + (c.lan ? " (LAN)" : ""));
    busy.values.push_back(std::clamp(c.utilisation, 0.0, 1.0));
    idle.values.push_back(1 - std::clamp(c.utilisation, 0.0, 1.0));
  }
  ChartFrame f{id_of(prefix, "chart-channels"), "Channel utilisation", "share of the run (%)", ""};
  f.left = 190;
  f.height = 120;
  const std::string source =
      run.channels.empty()
          ? "Share of the run each channel was busy: the union of its T-jobs' actual intervals (jobs CSV) over the run's time"
          : "Share of the run each channel resource (a medium its channels share: metrics.json resources[]) was busy";
  return figure(stacked_hbars(f, names, {busy, idle}, true, "%"),
                source + (all > use.size() ? "; the " + std::to_string(use.size()) + " busiest of " + std::to_string(all) + " shown." : "."));
}

std::string waits_table(const std::vector<WaitStats>& stats) {
  std::string h = "<table class=\"waits\">\n<tr><th>E-job type</th><th>E-jobs</th><th>p50</th><th>p95</th><th>max</th></tr>\n";
  for (const WaitStats& s : stats)
    h += "<tr><td>" + escape_xml(s.type) + "</td><td class=\"num\">" + std::to_string(s.count) + "</td><td class=\"num\">" +
         escape_xml(format_quantity(s.p50, "s")) + "</td><td class=\"num\">" + escape_xml(format_quantity(s.p95, "s")) +
         "</td><td class=\"num\">" + escape_xml(format_quantity(s.max, "s")) + "</td></tr>\n";
  return h + "</table>\n";
}

std::string waits_chart(const RunData& run, const std::string& prefix) {
  const std::vector<double> waits = queue_waits(run.activities);
  if (waits.empty())
    return missing("Queue waits", run.jobs_file.empty() ? "the run has no jobs CSV" : "no E-job with a start and a created time in the jobs CSV");
  const double hi = std::max(*std::max_element(waits.begin(), waits.end()), 1e-9);
  constexpr std::size_t kBins = 30;
  std::vector<double> edges, counts(kBins, 0.0);
  for (std::size_t i = 0; i <= kBins; ++i) edges.push_back(hi * static_cast<double>(i) / kBins);
  for (const double w : waits) counts[bin_of(w, 0, hi / kBins, kBins)] += 1;
  ChartFrame f{id_of(prefix, "chart-queue-waits"), "Queue waits of E-jobs", "wait (s)", "E-jobs"};
  return figure(histogram(f, edges, counts, "s"),
                "How long each started E-job waited in the queue: actual_start − created (jobs CSV), " +
                    std::to_string(waits.size()) + " E-jobs in " + std::to_string(kBins) + " bins.") +
         waits_table(wait_stats(run.activities));
}

std::string bar_tip(const GanttView::Bar& b) {
  const Activity& a = *b.activity;
  return (a.kind == 'E' ? "E-job " : "T-job ") + a.job + " (" + a.type + (a.block.empty() ? "" : ", " + a.block) + ") on " +
         a.where + ", " + (b.planned ? "planned " : "actual ") + format_quantity(b.start, "s") + " – " +
         format_quantity(b.end, "s") + ", " + a.state;
}

std::string gantt_chart(const RunData& run, const std::string& prefix) {
  GanttView g = gantt_view(run.activities);
  if (run.run_seconds > g.t0 && run.run_seconds < g.t1) g.t1 = run.run_seconds;  // not past the run's end
  if (g.bars.empty()) return missing("Planned and actual timelines", run.jobs_file.empty() ? "the run has no jobs CSV" : "the jobs CSV has no activity");
  std::vector<GanttBar> bars;
  for (const GanttView::Bar& b : g.bars)
    bars.push_back({b.row, b.start, b.end, b.planned,
                    b.planned ? colour::kPlanned : (b.activity->kind == 'E' ? colour::kBusy : colour::kTransfer), bar_tip(b)});
  ChartFrame f{id_of(prefix, "chart-gantt"), "Planned and actual timelines", "time (s)", ""};
  f.left = 150;
  f.height = 140;
  return figure(gantt(f, g.rows, bars, g.t0, g.t1),
                "Per row, the plan (upper, grey) and what ran (lower) of the " + std::to_string(g.rows.size()) +
                    " busiest compute devices and channels (most actual activity time): the first " +
                    std::to_string(g.shown_activities) + " of their " + std::to_string(g.row_activities) +
                    " activities (of " + std::to_string(g.all_activities) + " in the jobs CSV), from " +
                    format_quantity(g.t0, "s") + " to " + format_quantity(g.t1, "s") + ".");
}

std::string image_figure(const RunData& run, const std::string& prefix) {
  if (run.png.empty()) return missing("Image", "no " + run.label + ".png next to the metrics");
  return "<figure>\n<img id=\"" + escape_xml(id_of(prefix, "render-image")) + "\" class=\"render\" alt=\"the rendered image\" src=\"data:image/png;base64," +
         base64(run.png) + "\">\n<figcaption>" + escape_xml(run.label + ".png, the render's preview (the .exr holds the linear radiance)") +
         "</figcaption>\n</figure>\n";
}

// A number cell of compare.csv, 0 when empty or not a number.
double cell_number(const std::string& s) {
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && end == s.data() + s.size() && std::isfinite(v) ? v : 0.0;
}

// A cell of compare.csv: a number with 3 significant digits (the value as written in its
// tooltip), else the text.
std::string table_cell(const std::string& cell) {
  double v = 0;
  const auto [end, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), v);
  if (cell.empty() || ec != std::errc() || end != cell.data() + cell.size() || !std::isfinite(v))
    return "<td>" + escape_xml(cell) + "</td>";
  return "<td class=\"num\" title=\"" + escape_xml(cell) + "\">" + escape_xml(format_si(v)) + "</td>";
}

std::string compare_section(const RunFolder& folder) {
  const CompareTable& t = *folder.compare;
  std::string h = "<section id=\"compare\">\n<h2>Schedulers compared</h2>\n<div class=\"wide\"><table class=\"compare\">\n<tr>";
  for (const std::string& c : t.header) h += "<th>" + escape_xml(c) + "</th>";
  h += "</tr>\n";
  std::vector<std::string> names;
  Series whole{"rays/s over the run", colour::kLine, {}}, steady{"steady rays shot/s", colour::kBusy, {}};
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    const std::string name = t.cell(r, "scheduler");
    const bool has_run = std::any_of(folder.runs.begin(), folder.runs.end(), [&](const RunData& d) { return d.label == name; });
    h += "<tr>";
    for (std::size_t c = 0; c < t.rows[r].size(); ++c) {
      const std::string& cell = t.rows[r][c];
      if (t.header[c] == "scheduler" && has_run)
        h += "<td><a href=\"#run-" + escape_xml(id_safe(name)) + "\">" + escape_xml(cell) + "</a></td>";
      else
        h += table_cell(cell);
    }
    h += "</tr>\n";
    names.push_back(name);
    whole.values.push_back(cell_number(t.cell(r, "rays_per_second")));
    steady.values.push_back(cell_number(t.cell(r, "steady_rays_shot_per_second")));
  }
  h += "</table></div>\n";
  std::vector<Series> series{whole};
  if (std::any_of(steady.values.begin(), steady.values.end(), [](double v) { return v > 0; })) series.push_back(steady);
  ChartFrame f{"chart-compare-throughput", "Throughput per scheduler", "scheduler", "rays/s"};
  h += figure(bar_chart(f, names, series, "rays/s"),
              "From compare.csv: rays_per_second (rays intersected per second over the whole run)" +
                  std::string(series.size() > 1 ? " and steady_rays_shot_per_second (path tracing: each ray once, after the warm-up)" : "") +
                  ". Each scheduler's run has its section below.");
  return h + "</section>\n";
}

// The value of the header fact `label`, 0 when the run does not have it.
double fact_value(const RunData& run, const std::string& label) {
  for (const Fact& f : run.facts)
    if (f.label == label && f.value) return *f.value;
  return 0;
}

// A client sweep: throughput per client count, then a section per count.
std::string sweep_section(const RunFolder& folder) {
  std::vector<std::string> names;
  Series whole{"rays/s over the run", colour::kLine, {}}, steady{"steady rays shot/s", colour::kBusy, {}};
  std::string links;
  for (const RunData& run : folder.runs) {
    names.push_back(run.label);
    whole.values.push_back(fact_value(run, "rays/s over the run"));
    steady.values.push_back(fact_value(run, "steady rays shot/s"));
    links += std::string(links.empty() ? "" : ", ") + "<a href=\"#run-" + escape_xml(id_safe(run.label)) + "\">" +
             escape_xml(run.label) + "</a>";
  }
  ChartFrame f{"chart-sweep-throughput", "Throughput per client count", "clients", "rays/s"};
  return "<section id=\"sweep\">\n<h2>Client sweep</h2>\n" +
         figure(bar_chart(f, names, {steady, whole}, "rays/s"),
                "From each clients-N/metrics.json: path_trace.steady_rays_shot_per_second (each ray once, after the "
                "warm-up) and rays_per_second (rays intersected per second over the whole run).") +
         "<p>Runs: " + links + ".</p>\n</section>\n";
}

std::string run_title(const RunFolder& folder, const RunData& run) {
  switch (folder.kind) {
    case RunFolder::Kind::sweep: return "Sweep point " + run.label;
    case RunFolder::Kind::compare: return "Scheduler " + run.label;
    case RunFolder::Kind::render: return "Render " + run.label;
    case RunFolder::Kind::simulate: break;
  }
  return "Simulation";
}

std::string run_prefix(const RunFolder& folder, const RunData& run) {
  const bool several = folder.runs.size() > 1 || folder.kind == RunFolder::Kind::compare || folder.kind == RunFolder::Kind::sweep;
  return several ? id_safe(run.label) : "";
}

}  // namespace

std::string base64(const std::string& bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t v = 0;
    for (std::size_t k = 0; k < 3; ++k) v = v << 8 | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kAlphabet[(v >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

std::vector<std::string> chart_ids(const RunData& run, const std::string& prefix) {
  std::vector<std::string> ids;
  if (!throughput(run).values.empty()) ids.push_back(id_of(prefix, "chart-throughput"));
  if (!run.devices.empty()) ids.push_back(id_of(prefix, "chart-devices"));
  if (!channel_use(run).empty()) ids.push_back(id_of(prefix, "chart-channels"));
  if (!queue_waits(run.activities).empty()) ids.push_back(id_of(prefix, "chart-queue-waits"));
  if (!gantt_view(run.activities).bars.empty()) ids.push_back(id_of(prefix, "chart-gantt"));
  if (!run.png.empty()) ids.push_back(id_of(prefix, "render-image"));
  return ids;
}

std::string run_section(const RunData& run, const std::string& prefix) {
  std::string h = header_table(run);
  if (run.render) h += image_figure(run, prefix);
  h += throughput_chart(run, prefix);
  h += devices_chart(run, prefix);
  h += channels_chart(run, prefix);
  h += waits_chart(run, prefix);
  h += gantt_chart(run, prefix);
  return h;
}

std::string report_html(const RunFolder& folder) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n" << kHead << "<title>rayline report: " << escape_xml(folder.dir)
    << "</title>\n</head>\n<body>\n<h1>rayline report</h1>\n<p>Run folder <code>" << escape_xml(folder.dir) << "</code>";
  if (!folder.runs.empty() && !folder.runs.front().version.empty())
    h << ", written by rayline " << escape_xml(folder.runs.front().version);
  h << ".</p>\n";
  if (folder.compare) h << compare_section(folder);
  if (folder.kind == RunFolder::Kind::sweep) h << sweep_section(folder);
  for (const RunData& run : folder.runs) {
    const std::string prefix = run_prefix(folder, run);
    h << "<section class=\"run\" id=\"run-" << escape_xml(prefix.empty() ? "main" : prefix) << "\">\n<h2>"
      << escape_xml(run_title(folder, run)) << "</h2>\n"
      << run_section(run, prefix) << "</section>\n";
  }
  h << "</body>\n</html>\n";
  return h.str();
}

}  // namespace rayline::report

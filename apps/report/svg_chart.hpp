// A small SVG chart writer for `rayline report`: linear scales, readable ticks, and the
// charts the report draws (lines, grouped bars, a histogram, horizontal stacked bars, a
// Gantt chart), each one <svg> element with an id, a title and a legend. Every text that
// reaches the SVG is escaped. No JavaScript: the charts are static markup, and a <title>
// inside a shape is its tooltip in a browser.
#pragma once
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace rayline::report {

// Text for XML content and attribute values: & < > " ' escaped; control characters other
// than tab and newline (not allowed in XML) become U+FFFD.
std::string escape_xml(std::string_view text);

// Maps [d0, d1] onto [r0, r1] linearly; a zero-width domain maps everything onto r0.
struct LinearScale {
  double d0 = 0, d1 = 1, r0 = 0, r1 = 1;
  double operator()(double v) const;
};

// Tick values at a step of 1, 2 or 5 x 10^n that cover [lo, hi] with at most `max_ticks`
// + 1 values; the first tick <= lo and the last >= hi. lo == hi gives [lo, lo + 1] covered.
struct Ticks {
  std::vector<double> values;
  double step = 1;
};
Ticks nice_ticks(double lo, double hi, int max_ticks = 6);

// A tick label: the value with as many decimals as the step needs, and k, M, G, T for
// thousands and up ("0", "0.5M", "1M", "1.5M"); never "-0".
std::string format_tick(double value, double step);
// 3 significant digits and an SI suffix for thousands and up: "6.31M", "0.423", "12".
std::string format_si(double value);
// A value for a table or tooltip with 3 significant digits and its unit: "s" as µs, ms or
// s ("664 µs"); "B" as B, kB, MB, GB, TB ("1.46 GB"); "%" (a fraction) as a percentage
// ("97.6 %"); other units after an SI suffix ("3.67M rays/s"); no unit: a plain number
// (whole numbers in full).
std::string format_quantity(double value, std::string_view unit);

// Colours the report uses (busy, setup, fetching, idle, planned, transfer).
namespace colour {
inline constexpr const char* kBusy = "#2f9e44";
inline constexpr const char* kSetup = "#f08c00";
inline constexpr const char* kFetching = "#1c7ed6";
inline constexpr const char* kIdle = "#ced4da";
inline constexpr const char* kPlanned = "#868e96";
inline constexpr const char* kTransfer = "#1c7ed6";
inline constexpr const char* kLine = "#5f3dc4";
}  // namespace colour

// The frame every chart shares: size, id (unique in the page), title and axis labels.
struct ChartFrame {
  std::string id, title, x_label, y_label;
  int width = 760, height = 300;
  int left = 72, right = 16, top = 44, bottom = 48;  // margins around the plot area
};

// One named series of values, drawn in `colour`.
struct Series {
  std::string name, colour;
  std::vector<double> values;
};

// Lines through (x[i], series.values[i]) over a numeric x axis; y from 0.
std::string line_chart(const ChartFrame& frame, const std::vector<double>& x, const std::vector<Series>& series,
                       std::string_view y_unit = "");

// Vertical bars, grouped per category (one bar per series); y from 0.
std::string bar_chart(const ChartFrame& frame, const std::vector<std::string>& categories,
                      const std::vector<Series>& series, std::string_view y_unit = "");

// A histogram: counts[i] over [edges[i], edges[i + 1]) (edges.size() == counts.size() + 1).
std::string histogram(const ChartFrame& frame, const std::vector<double>& edges, const std::vector<double>& counts,
                      std::string_view x_unit = "");

// Horizontal bars, one row per label, the series stacked left to right. With `shares`,
// each row is drawn as a share of its total (0–100 %); else on a common value axis.
// The height grows with the rows (frame.height is the minimum).
std::string stacked_hbars(const ChartFrame& frame, const std::vector<std::string>& rows,
                          const std::vector<Series>& series, bool shares, std::string_view value_unit = "");

// One rectangle of a Gantt chart: in row `row`, planned (upper half) or actual (lower).
struct GanttBar {
  std::size_t row = 0;
  double start = 0, end = 0;
  bool planned = false;
  std::string colour, tip;
};
// Rows of planned and actual intervals over the time window [t0, t1], x in seconds.
std::string gantt(const ChartFrame& frame, const std::vector<std::string>& rows, const std::vector<GanttBar>& bars,
                  double t0, double t1);

}  // namespace rayline::report

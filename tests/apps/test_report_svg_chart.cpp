// The SVG chart writer of `rayline report`: scales, ticks, labels, escaping, and the
// shapes each chart draws.
#include <gtest/gtest.h>

#include <string>

#include "apps/report/svg_chart.hpp"

namespace rayline::report {
namespace {

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + what.size())) ++n;
  return n;
}

// The width attribute of the rect whose tooltip starts with `tip` (-1 when there is none).
double rect_width(const std::string& svg, const std::string& tip) {
  const std::size_t title = svg.find("><title>" + tip);
  if (title == std::string::npos) return -1;
  const std::size_t rect = svg.rfind("<rect ", title);
  const std::size_t width = svg.find(" width=\"", rect);
  if (rect == std::string::npos || width == std::string::npos || width > title) return -1;
  return std::stod(svg.substr(width + 8));
}

TEST(ReportSvg, EscapesMarkupQuotesAndControlCharacters) {
  EXPECT_EQ(escape_xml("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
  EXPECT_EQ(escape_xml(std::string("x\x01y\tz")), "x\xEF\xBF\xBDy\tz");
  EXPECT_EQ(escape_xml("µs – ok"), "µs – ok");  // UTF-8 passes through
}

TEST(ReportSvg, LinearScaleMapsTheDomainOntoTheRange) {
  const LinearScale y{0, 100, 250, 50};  // an upward y axis
  EXPECT_DOUBLE_EQ(y(0), 250);
  EXPECT_DOUBLE_EQ(y(100), 50);
  EXPECT_DOUBLE_EQ(y(25), 200);
  EXPECT_DOUBLE_EQ((LinearScale{3, 3, 10, 20})(7), 10);  // empty domain: no division by zero
}

TEST(ReportSvg, TicksAreRoundStepsCoveringTheRange) {
  const Ticks a = nice_ticks(0, 97, 5);
  EXPECT_DOUBLE_EQ(a.step, 20);
  ASSERT_EQ(a.values.size(), 6u);
  EXPECT_DOUBLE_EQ(a.values.front(), 0);
  EXPECT_DOUBLE_EQ(a.values.back(), 100);
  const Ticks b = nice_ticks(0, 1.5e6, 5);
  EXPECT_DOUBLE_EQ(b.step, 5e5);
  EXPECT_EQ(b.values.size(), 4u);
  const Ticks c = nice_ticks(0.013, 0.052, 8);
  EXPECT_DOUBLE_EQ(c.step, 0.005);
  EXPECT_LE(c.values.front(), 0.013);
  EXPECT_GE(c.values.back(), 0.052);
  const Ticks d = nice_ticks(4, 4);  // one value: still an axis
  EXPECT_GE(d.values.size(), 2u);
  EXPECT_LE(d.values.front(), 4);
  const Ticks e = nice_ticks(-3, 7, 5);
  EXPECT_LE(e.values.front(), -3);
  EXPECT_GE(e.values.back(), 7);
  EXPECT_DOUBLE_EQ(e.step, 2);
}

TEST(ReportSvg, TickLabelsAreShortAndReadable) {
  EXPECT_EQ(format_tick(0, 5e5), "0");
  EXPECT_EQ(format_tick(-0.0, 1), "0");
  EXPECT_EQ(format_tick(5e5, 5e5), "500k");
  EXPECT_EQ(format_tick(1e6, 5e5), "1M");
  EXPECT_EQ(format_tick(1.5e6, 5e5), "1.5M");
  EXPECT_EQ(format_tick(1.2e9, 2e8), "1.2G");
  EXPECT_EQ(format_tick(0.2, 0.1), "0.2");
  EXPECT_EQ(format_tick(0.015, 0.005), "0.015");
  EXPECT_EQ(format_tick(40, 20), "40");
  EXPECT_EQ(format_tick(-2, 2), "-2");
}

TEST(ReportSvg, QuantitiesCarryTheirUnit) {
  EXPECT_EQ(format_quantity(0.000664, "s"), "664 µs");
  EXPECT_EQ(format_quantity(0.656, "s"), "656 ms");
  EXPECT_EQ(format_quantity(3.46, "s"), "3.46 s");
  EXPECT_EQ(format_quantity(0.976, "%"), "97.6 %");
  EXPECT_EQ(format_quantity(1464101198, "B"), "1.46 GB");
  EXPECT_EQ(format_quantity(400, "B"), "400 B");
  EXPECT_EQ(format_quantity(3673391.3, "rays/s"), "3.67 M rays/s");  // as the command line prints rates
  EXPECT_EQ(format_quantity(3097, ""), "3097");
  EXPECT_EQ(format_quantity(2.5, ""), "2.5");
}

TEST(ReportSvg, SiFormatKeepsThreeSignificantDigits) {
  EXPECT_EQ(format_si(6314550), "6.31M");
  EXPECT_EQ(format_si(0.422702), "0.423");
  EXPECT_EQ(format_si(12), "12");
  EXPECT_EQ(format_si(3.2768e-05), "3.28e-05");
  EXPECT_EQ(format_si(-1500), "-1.5k");
}

TEST(ReportSvg, LineChartHasItsIdTitleAxesAndOnePointPerValue) {
  ChartFrame f{"chart-x", "Rays <per> second", "time (s)", "rays/s"};
  const std::string svg = line_chart(f, {0.5, 1.5, 2.5}, {{"rays/s", "#000", {0, 2e6, 1e6}}}, "rays/s");
  EXPECT_EQ(svg.rfind("<svg id=\"chart-x\"", 0), 0u);
  EXPECT_NE(svg.find("Rays &lt;per&gt; second"), std::string::npos);
  EXPECT_EQ(svg.find("Rays <per>"), std::string::npos);
  EXPECT_EQ(count(svg, "<polyline"), 1u);
  EXPECT_NE(svg.find(">2M</text>"), std::string::npos);  // top tick of the y axis
  EXPECT_NE(svg.find("rays/s: 2 M rays/s at"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

TEST(ReportSvg, StackedSharesSplitEachRowByItsTotal) {
  ChartFrame f{"chart-s", "Shares", "", ""};
  f.left = 100;
  f.right = 20;
  f.width = 520;  // a 400 px plot
  const std::string svg =
      stacked_hbars(f, {"dev0", "dev1"}, {{"busy", "#0f0", {1, 6}}, {"idle", "#ccc", {3, 2}}}, true, "s");
  EXPECT_NEAR(rect_width(svg, "dev0, busy: 25 %"), 100, 0.11);
  EXPECT_NEAR(rect_width(svg, "dev0, idle: 75 %"), 300, 0.11);
  EXPECT_NEAR(rect_width(svg, "dev1, busy: 75 %"), 300, 0.11);
  EXPECT_NE(svg.find("dev1, busy: 75 % (6 s)"), std::string::npos);
  EXPECT_NE(svg.find(">busy</text>"), std::string::npos);  // legend
  EXPECT_NE(svg.find(">100</text>"), std::string::npos);   // the share axis ends at 100 %
}

TEST(ReportSvg, HistogramDrawsOneBarPerBin) {
  ChartFrame f{"chart-h", "Waits", "wait (s)", "jobs"};
  const std::string svg = histogram(f, {0, 1, 2, 3}, {4, 0, 2}, "s");
  EXPECT_EQ(count(svg, "<rect x="), 3u);
  EXPECT_NE(svg.find("1 s – 2 s: 0"), std::string::npos);
}

TEST(ReportSvg, GanttDrawsOnlyBarsInItsWindowAndRows) {
  ChartFrame f{"chart-g", "Gantt", "time (s)", ""};
  const std::vector<GanttBar> bars{{0, 1, 2, true, "#888", "p0"},
                                   {0, 1.5, 2.5, false, "#0f0", "a0"},
                                   {1, 9, 10, false, "#00f", "late"},   // after the window
                                   {5, 1, 2, false, "#00f", "no row"}};  // no such row
  const std::string svg = gantt(f, {"W.cpu0", "W.disk"}, bars, 0, 4);
  EXPECT_NE(svg.find("<title>p0</title>"), std::string::npos);
  EXPECT_NE(svg.find("<title>a0</title>"), std::string::npos);
  EXPECT_EQ(svg.find("late"), std::string::npos);
  EXPECT_EQ(svg.find("no row"), std::string::npos);
  EXPECT_NE(svg.find(">W.disk</text>"), std::string::npos);
}

TEST(ReportSvg, BarChartLabelsEveryCategory) {
  ChartFrame f{"chart-b", "Per scheduler", "", "rays/s"};
  const std::string svg = bar_chart(f, {"gmb", "budge"}, {{"rays/s", "#000", {3e6, 1e6}}}, "rays/s");
  EXPECT_NE(svg.find(">gmb</text>"), std::string::npos);
  EXPECT_NE(svg.find(">budge</text>"), std::string::npos);
  EXPECT_NE(svg.find("gmb: 3 M rays/s"), std::string::npos);
}

}  // namespace
}  // namespace rayline::report

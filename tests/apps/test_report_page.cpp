// The HTML page of `rayline report` on hand-made run folders: every chart there, the
// numbers right, nothing loaded from outside.
#include <gtest/gtest.h>

#include <random>

#include "apps/report/report_page.hpp"
#include "apps/report/run_files.hpp"
#include "apps/run_folder_fixture.hpp"
#include "cli/scratch_test.hpp"
#include "common/error.hpp"

namespace rayline::report {
namespace {

using rayline::testing::ScratchTest;

bool has(const std::string& page, const std::string& what) { return page.find(what) != std::string::npos; }

// Every <svg id="..."> of the page, in order.
std::vector<std::string> svg_ids(const std::string& page) {
  std::vector<std::string> ids;
  const std::string open = "<svg id=\"";
  for (std::size_t at = page.find(open); at != std::string::npos; at = page.find(open, at + 1)) {
    const std::size_t from = at + open.size();
    ids.push_back(page.substr(from, page.find('"', from) - from));
  }
  return ids;
}

// An attribute value a browser cannot draw: NaN or an infinity.
bool has_non_number(const std::string& page) {
  for (const char* bad : {"=\"nan", "=\"-nan", "=\"inf", "=\"-inf"})
    if (has(page, bad)) return true;
  return false;
}

// Nothing that a browser would fetch: every src and href inside the page (a data: URI or
// an anchor), no script, no stylesheet link.
void expect_self_contained(const std::string& page) {
  for (const std::string attr : {" src=\"", " href=\""})
    for (std::size_t at = page.find(attr); at != std::string::npos; at = page.find(attr, at + 1)) {
      const std::string value = page.substr(at + attr.size(), 5);
      EXPECT_TRUE(value == "data:" || value[0] == '#') << page.substr(at, 60);
    }
  EXPECT_FALSE(has(page, "<script"));
  EXPECT_FALSE(has(page, "<link"));
  EXPECT_TRUE(has(page, "Content-Security-Policy\" content=\"default-src 'none'"));
}

class ReportPage : public ScratchTest {};

TEST(ReportBase64, MatchesRfc4648) {
  EXPECT_EQ(base64(""), "");
  EXPECT_EQ(base64("f"), "Zg==");
  EXPECT_EQ(base64("fo"), "Zm8=");
  EXPECT_EQ(base64("foo"), "Zm9v");
  EXPECT_EQ(base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64(std::string("\xff\x00\x80", 3)), "/wCA");
}

TEST_F(ReportPage, SimulatePageHasEveryChartAndTheHeader) {
  rayline::testing::write_simulate_run(dir_);
  const RunFolder f = read_run_folder(dir_.string());
  const std::string page = report_html(f);
  const std::vector<std::string> expected{"chart-throughput", "chart-devices", "chart-channels", "chart-queue-waits",
                                          "chart-gantt"};
  EXPECT_EQ(chart_ids(f.runs[0], ""), expected);
  EXPECT_EQ(svg_ids(page), expected);
  EXPECT_TRUE(has(page, "<code>rayline simulate --out x &lt;b&gt;</code>"));  // the command, escaped
  EXPECT_TRUE(has(page, "rayline 0.1.0"));
  EXPECT_TRUE(has(page, "<th>LAN utilisation (mean)</th><td>25 %</td>"));
  EXPECT_TRUE(has(page, "<th>rays/s over the run</th><td>2.5 M rays/s</td>"));
  EXPECT_TRUE(has(page, "A.sata, busy: 50 %"));          // channel utilisation from resources[]
  EXPECT_TRUE(has(page, "lan:A-&gt;B (LAN), busy: 12.5 %"));
  EXPECT_TRUE(has(page, "A.gpu0, busy: 75 % (3 s)"));     // device shares
  EXPECT_TRUE(has(page, "rays/s: 4 M rays/s at"));          // the last second of the series
  EXPECT_TRUE(has(page, ">Throughput: rays traced per simulated second</text>"));
  // Queue waits per type: RayIntersect 1 s; Shade 0 s and 3 s; all three.
  EXPECT_TRUE(has(page, "<tr><td>RayIntersect</td><td class=\"num\">1</td><td class=\"num\">1 s</td>"));
  EXPECT_TRUE(has(page, "<tr><td>Shade</td><td class=\"num\">2</td>"));
  EXPECT_TRUE(has(page, "<tr><td>all</td><td class=\"num\">3</td><td class=\"num\">1 s</td>"));
  // The Gantt chart: the planned-only E-job has a planned bar and no actual one.
  EXPECT_TRUE(has(page, "E-job j3 (RayIntersect) on A.cpu0, planned 3 s – 4 s, planned"));
  EXPECT_FALSE(has(page, "E-job j3 (RayIntersect) on A.cpu0, actual"));
  EXPECT_TRUE(has(page, "the first 5 of their 5 activities"));
  EXPECT_FALSE(has(page, "class=\"missing\""));
  expect_self_contained(page);
}

TEST_F(ReportPage, ChartsWithoutDataSayWhy) {
  rayline::testing::write_text_file(dir_ / "metrics.json", rayline::testing::simulate_metrics());
  const std::string page = report_html(read_run_folder(dir_.string()));
  EXPECT_EQ(svg_ids(page), (std::vector<std::string>{"chart-throughput", "chart-devices", "chart-channels"}));
  EXPECT_TRUE(has(page, "<p class=\"missing\">Queue waits: the run has no jobs CSV</p>"));
  EXPECT_TRUE(has(page, "<p class=\"missing\">Planned and actual timelines: the run has no jobs CSV</p>"));
}

TEST_F(ReportPage, ComparePageHasTheTableBarsAndASectionPerScheduler) {
  rayline::testing::write_compare_run(dir_);
  const std::string page = report_html(read_run_folder(dir_.string()));
  const std::vector<std::string> ids = svg_ids(page);
  ASSERT_FALSE(ids.empty());
  EXPECT_EQ(ids[0], "chart-compare-throughput");
  for (const std::string s : {"gmb", "budge"})
    for (const std::string c : {"chart-throughput", "chart-devices", "chart-channels", "chart-queue-waits", "chart-gantt"})
      EXPECT_NE(std::find(ids.begin(), ids.end(), s + "-" + c), ids.end()) << s << "-" << c;
  EXPECT_TRUE(has(page, "<td><a href=\"#run-gmb\">gmb</a></td>"));
  EXPECT_TRUE(has(page, "<section class=\"run\" id=\"run-budge\">"));
  EXPECT_TRUE(has(page, "<td>gmb{k=2s; a, b}</td>"));
  EXPECT_TRUE(has(page, "<td class=\"num\" title=\"1500000\">1.5M</td>"));  // numbers shortened
  EXPECT_TRUE(has(page, "gmb, rays/s over the run: 3 M rays/s"));
  EXPECT_TRUE(has(page, "budge, steady rays shot/s: 500 k rays/s"));
  expect_self_contained(page);
}

TEST_F(ReportPage, SweepPageHasThroughputPerClientCountAndASectionPerPoint) {
  rayline::testing::write_sweep_run(dir_);
  const std::string page = report_html(read_run_folder(dir_.string()));
  const std::vector<std::string> ids = svg_ids(page);
  ASSERT_EQ(ids.size(), 11u);
  EXPECT_EQ(ids[0], "chart-sweep-throughput");
  EXPECT_EQ(ids[1], "clients-2-chart-throughput");
  EXPECT_EQ(ids[10], "clients-10-chart-gantt");
  EXPECT_TRUE(has(page, "clients-10, rays/s over the run: 2.5 M rays/s"));
  EXPECT_TRUE(has(page, "<a href=\"#run-clients-2\">clients-2</a>"));
  expect_self_contained(page);
}

TEST_F(ReportPage, SeveralRendersInOneFolderEachGetASection) {
  rayline::testing::write_render_run(dir_, "a");
  rayline::testing::write_render_run(dir_, "b");
  const std::string page = report_html(read_run_folder(dir_.string()));
  EXPECT_TRUE(has(page, "<img id=\"a-render-image\""));
  EXPECT_TRUE(has(page, "<img id=\"b-render-image\""));
  EXPECT_TRUE(has(page, "<svg id=\"b-chart-gantt\""));
}

TEST_F(ReportPage, RenderPageEmbedsTheImageAndDerivesChannelsFromTransfers) {
  rayline::testing::write_render_run(dir_);
  const RunFolder f = read_run_folder(dir_.string());
  const std::string page = report_html(f);
  EXPECT_TRUE(has(page, "<img id=\"render-image\" class=\"render\" alt=\"the rendered image\" src=\"data:image/png;base64,Zm9vYmFy\">"));
  EXPECT_EQ(chart_ids(f.runs[0], "").back(), "render-image");
  EXPECT_TRUE(has(page, "W.disk:disk-&gt;ram, busy: 50 %"));  // [0, 0.5] and [0.25, 1] over 2 s
  EXPECT_TRUE(has(page, "<th>resolution</th><td>64 x 48</td>"));
  EXPECT_TRUE(has(page, "<th>scene</th><td>scenes/cornell.json</td>"));
  EXPECT_TRUE(has(page, ">Throughput: ray bytes of the E-jobs finished per second</text>"));
  expect_self_contained(page);
}

// Mutated run files: each one is read and charted or refused as bad input (InputError),
// never a crash or another exception, and no chart holds a coordinate that is not a number.
TEST_F(ReportPage, MutatedRunFilesAreChartedOrRefusedAsBadInput) {
  const std::string metrics = rayline::testing::simulate_metrics(), jobs = rayline::testing::simulate_jobs();
  const std::string alphabet = "0123456789.-e,\"{}[]:\n x";
  std::mt19937 rng(7);
  std::size_t refused = 0;
  for (int i = 0; i < 400; ++i) {
    std::string m = metrics, j = jobs;
    std::string& target = i % 2 ? j : m;
    for (int k = 0; k < 1 + i % 3; ++k) {
      const std::size_t at = rng() % target.size();
      if (rng() % 4 == 0)
        target.erase(at, 1 + rng() % 8);
      else
        target[at] = alphabet[rng() % alphabet.size()];
    }
    rayline::testing::write_text_file(dir_ / "metrics.json", m);
    rayline::testing::write_text_file(dir_ / "jobs.csv", j);
    try {
      const std::string page = report_html(read_run_folder(dir_.string()));
      EXPECT_FALSE(has_non_number(page)) << m << j;
    } catch (const InputError&) {
      ++refused;
    }
  }
  EXPECT_GT(refused, 50u);  // the mutations reach the checks
  EXPECT_LT(refused, 400u);
}

TEST_F(ReportPage, ValuesNearTheLargestDoubleStillGiveNumbers) {
  rayline::testing::write_text_file(dir_ / "metrics.json",
                                    R"({"rays_per_second_series": [1e308, 1e308], "simulated_s": 1e308,
                                        "devices": [{"name": "a", "busy_s": 1e308, "fetching_s": 1e308, "idle_s": 1e308}],
                                        "resources": [{"resource": "r", "utilisation": 1e308}]})");
  rayline::testing::write_text_file(dir_ / "jobs.csv", rayline::testing::simulate_jobs() +
                                                           "5,E,j,Shade,A.cpu0,,1e308,0,1e308,-1e308,1e308,done,-1e308\n");
  const std::string page = report_html(read_run_folder(dir_.string()));
  EXPECT_FALSE(has_non_number(page));
  EXPECT_EQ(svg_ids(page).size(), 5u);
}

}  // namespace
}  // namespace rayline::report

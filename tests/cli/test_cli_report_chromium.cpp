// `rayline report` pages loaded in headless Chromium: a small simulate, compare and render
// run each get their page, and the DOM Chromium builds holds every chart with its shapes,
// while Chromium prints no console message (the page's Content-Security-Policy turns any
// attempt to load something from outside into one). Skips when Chromium is not installed
// (scripts/setup.sh installs Debian's `chromium`); $RAYLINE_CHROMIUM names another binary.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_run.hpp"
#include "cli/scratch_test.hpp"

namespace fs = std::filesystem;
using rayline::testing::rayline_cli;

namespace {

// $RAYLINE_CHROMIUM, else chromium or chromium-browser on the PATH; empty when none.
std::string find_chromium() {
  if (const char* env = std::getenv("RAYLINE_CHROMIUM"); env && *env) return env;
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin");
  for (std::string dir; std::getline(dirs, dir, ':');)
    for (const char* name : {"chromium", "chromium-browser"}) {
      const fs::path p = fs::path(dir) / name;
      if (::access(p.c_str(), X_OK) == 0) return p.string();
    }
  return {};
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class ReportChromium : public rayline::testing::ScratchTest {
 protected:
  void SetUp() override {
    ScratchTest::SetUp();
    chromium_ = find_chromium();
    if (chromium_.empty())
      GTEST_SKIP() << "Chromium is not installed (apt-get install chromium; scripts/setup.sh does), or set RAYLINE_CHROMIUM";
  }

  // `rayline report DIR`, then DIR/report.html loaded in headless Chromium: its DOM and log.
  void load_report(const std::string& dir) {
    const auto r = rayline_cli("report " + dir);
    ASSERT_EQ(r.code, 0) << r.all;
    const std::string cmd = "timeout 120 '" + chromium_ +
                            "' --headless --no-sandbox --disable-gpu --no-first-run --disable-extensions "
                            "--user-data-dir='" + path("profile") + "' --enable-logging=stderr --v=0 --dump-dom 'file://" +
                            dir + "/report.html' > '" + path("dom.html") + "' 2> '" + path("chromium.log") + "'";
    const int rc = std::system(cmd.c_str());
    log_ = slurp(path("chromium.log"));
    dom_ = slurp(path("dom.html"));
    ASSERT_EQ(rc, 0) << cmd << "\n" << log_;
    ASSERT_NE(dom_.find("</html>"), std::string::npos) << "no DOM dumped\n" << log_;
  }

  // The chart `id` is in the DOM as an <svg> with shapes in it.
  void expect_chart(const std::string& id) const {
    const std::size_t at = dom_.find("<svg id=\"" + id + "\"");
    ASSERT_NE(at, std::string::npos) << "no <svg id=\"" << id << "\"> in the rendered DOM";
    const std::size_t end = dom_.find("</svg>", at);
    ASSERT_NE(end, std::string::npos) << id;
    const std::string svg = dom_.substr(at, end - at);
    EXPECT_TRUE(svg.find("<rect") != std::string::npos || svg.find("<polyline") != std::string::npos)
        << id << " has no shapes";
    EXPECT_NE(svg.find("<text"), std::string::npos) << id << " has no labels";
  }

  // No line of Chromium's log comes from the page's console (errors, warnings, CSP
  // violations all go there).
  void expect_no_console_message() const {
    std::stringstream lines(log_);
    for (std::string line; std::getline(lines, line);)
      EXPECT_EQ(line.find(":CONSOLE"), std::string::npos) << line;
  }

  std::string chromium_, dom_, log_;
};

const std::vector<std::string> kRunCharts{"chart-throughput", "chart-devices", "chart-channels", "chart-queue-waits",
                                          "chart-gantt"};

TEST_F(ReportChromium, SimulatePageShowsEveryChart) {
  const auto r = rayline_cli("simulate --workload museum --clients 2 --duration 4s --start warm --no-progress --out " +
                             path("sim"));
  ASSERT_EQ(r.code, 0) << r.all;
  load_report(path("sim"));
  for (const std::string& id : kRunCharts) expect_chart(id);
  expect_no_console_message();
}

TEST_F(ReportChromium, ComparePageShowsTheSchedulersAndEachRunsCharts) {
  const auto r = rayline_cli("compare --platform paper-2A --workload museum --clients 2 --duration 4s --start warm --schedulers gmb,budge --out " +
                             path("cmp"));
  ASSERT_EQ(r.code, 0) << r.all;
  load_report(path("cmp"));
  expect_chart("chart-compare-throughput");
  for (const std::string s : {"gmb", "budge"})
    for (const std::string& id : kRunCharts) expect_chart(s + "-" + id);
  EXPECT_NE(dom_.find("<a href=\"#run-budge\">budge</a>"), std::string::npos);
  expect_no_console_message();
}

TEST_F(ReportChromium, RenderPageShowsTheImageAndEveryChart) {
  const auto r = rayline_cli("render --scene " + std::string(RAYLINE_SCENES_DIR) +
                             "/cornell.json --resolution 48x36 --spp 2 -j 2 -q --out " + path("r/room.exr"));
  ASSERT_EQ(r.code, 0) << r.all;
  load_report(path("r"));
  EXPECT_NE(dom_.find("<img id=\"render-image\" class=\"render\" alt=\"the rendered image\" src=\"data:image/png;base64,iVBORw0KGgo"),
            std::string::npos);
  for (const std::string& id : kRunCharts) expect_chart(id);
  expect_no_console_message();
}

}  // namespace

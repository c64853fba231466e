// The HTML page of `rayline report`: one self-contained document (inline CSS and SVG, the
// render's PNG as a data URI, a Content-Security-Policy that forbids loading anything)
// for a simulate, compare or render folder (apps/report/run_files.hpp).
//
// Every chart is an <svg> whose id names it (docs/report.md): chart-throughput,
// chart-devices, chart-channels, chart-queue-waits, chart-gantt, and the render's
// <img id="render-image">; in a compare page chart-compare-throughput, and each
// scheduler's charts with its name in front ("gmb-chart-devices"); in a client sweep
// chart-sweep-throughput and "clients-N-chart-devices"; with several renders in one
// folder, the image stem in front. A chart whose data
// the run does not have is replaced by a paragraph of class "missing" saying why.
#pragma once
#include <string>
#include <vector>

#include "apps/report/run_files.hpp"

namespace rayline::report {

// The ids of the charts a run's section holds, prefix included (what the page draws).
std::vector<std::string> chart_ids(const RunData& run, const std::string& prefix);

// The whole page.
std::string report_html(const RunFolder& folder);

// A run's section (header facts and charts); ids are prefixed with `prefix` + "-" unless empty.
std::string run_section(const RunData& run, const std::string& prefix);

// Base64 (RFC 4648, with padding) of raw bytes, for data URIs.
std::string base64(const std::string& bytes);

}  // namespace rayline::report

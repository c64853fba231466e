// The paper's measurement (Sec. 6): "we increase the number of clients until each method
// reaches its peak performance". A client sweep that finds the peak by itself: client
// counts double from 1; the sweep stops once two points in a row failed to beat the best
// steady throughput so far by more than `gain` (2 %) — a point that is not in a steady
// state (its rays alive still growing: an offered load not absorbed, or in-flight budgets
// still filling) counts as such a failure — or at `max_clients` (the workload's limit: a
// sweep still rising at 512 clients measures 1023 last). The peak is the best steady
// point measured.
#pragma once
#include <vector>

#include "workload/path_trace_graph.hpp"

namespace rayline::sim {

struct PeakSearch {
  int max_clients = kMaxPtClients;  // the path-tracing workload's limit
  double gain = 0.02;
};

struct PeakPoint {
  int clients = 0;
  double rate = 0;      // steady rays shot per second
  bool steady = true;   // metrics.json path_trace.steady.steady
};

// The next client count to measure after `points` (in the order measured), or 0 when the
// sweep is over.
int next_peak_point(const std::vector<PeakPoint>& points, const PeakSearch& opt = {});

// The best steady point of `points` (the first of equals); the best point when none is
// steady; {0, 0} when there is none.
PeakPoint peak_of(const std::vector<PeakPoint>& points);

}  // namespace rayline::sim

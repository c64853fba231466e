// The paper's measurement (Sec. 6): "we increase the number of clients until each method
// reaches its peak performance". A client sweep that finds the peak by itself: client
// counts double from 1; the sweep stops once two points in a row failed to beat the best
// throughput so far by more than `gain` (2 %), or at `max_clients` (the workload's limit:
// a sweep still rising at 512 clients measures 1023 last). The peak is the best point
// measured.
#pragma once
#include <utility>
#include <vector>

#include "workload/path_trace_graph.hpp"

namespace rayline::sim {

struct PeakSearch {
  int max_clients = kMaxPtClients;  // the path-tracing workload's limit
  double gain = 0.02;
};

// The next client count to measure after `points` ((clients, throughput), in the order
// measured), or 0 when the sweep is over.
int next_peak_point(const std::vector<std::pair<int, double>>& points, const PeakSearch& opt = {});

// The best point of `points` (the first of equals); {0, 0} when there is none.
std::pair<int, double> peak_of(const std::vector<std::pair<int, double>>& points);

}  // namespace rayline::sim

// Test support: overlapping complete events in a Chrome trace. Perfetto drops an "X" event
// that overlaps another on its (pid, tid) track (slice_drop_overlapping_complete_event), so
// Rayline's traces keep every track's slices apart.
#pragma once
#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

namespace rayline::testing {

struct TraceCheck {
  std::size_t slices = 0, overlaps = 0, tracks = 0;
};

inline TraceCheck check_trace(const nlohmann::json& trace) {
  TraceCheck c;
  std::map<std::pair<int, int>, std::vector<std::pair<double, double>>> by_track;
  for (const auto& e : trace.at("traceEvents"))
    if (e.at("ph") == "X") {
      by_track[{e.at("pid").get<int>(), e.at("tid").get<int>()}].emplace_back(e.at("ts").get<double>(),
                                                                                 e.at("dur").get<double>());
      ++c.slices;
    }
  c.tracks = by_track.size();
  for (auto& [track, v] : by_track) {
    std::sort(v.begin(), v.end());
    for (std::size_t i = 1; i < v.size(); ++i)
      if (v[i].first < v[i - 1].first + v[i - 1].second) ++c.overlaps;
  }
  return c;
}

}  // namespace rayline::testing

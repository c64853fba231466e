// metrics.json of `rayline render` (keys documented in README, "Rendering"). nlohmann_json
// stays inside render_metrics.cpp.
#pragma once
#include <string>
#include <vector>

#include "sched/timeline/schedule.hpp"

namespace rayline::engine {

struct RenderResult;

std::string render_metrics_json(const RenderResult& r, const Schedule& s, const std::vector<double>& lane_busy);

}  // namespace rayline::engine

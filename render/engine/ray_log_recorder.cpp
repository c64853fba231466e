#include "render/engine/ray_log_recorder.hpp"

#include <algorithm>
#include <stdexcept>
#include <utility>
#include <vector>

namespace rayline::engine {

void RayLogRecorder::begin(std::uint32_t width, std::uint32_t height, std::uint32_t spp, std::uint32_t cells) {
  log_ = RayLog{};
  log_.width = width, log_.height = height, log_.spp = spp, log_.cells = cells;
  pixels_ = std::uint64_t(width) * height;
  log_.entry.assign(pixels_ * spp, RayLog::kNoVisit);
  live_.clear();
}

std::uint64_t RayLogRecorder::key(const trace::RayRecord& r) const {
  if (r.bounce > 255) throw std::runtime_error("ray log: more than 255 bounces");
  return (camera_index(r) << 9) | (std::uint64_t(r.bounce) << 1) | std::uint64_t(r.kind);
}

std::uint32_t RayLogRecorder::add_visit(const trace::RayRecord& r) {
  if (log_.visits.size() >= RayLog::kNoVisit - 1) throw std::runtime_error("ray log: more than 2^32 visits");
  RayVisit v;
  v.cell = r.cell;
  v.bounce = r.bounce;
  v.kind = static_cast<std::uint8_t>(r.kind);
  log_.visits.push_back(v);
  return static_cast<std::uint32_t>(log_.visits.size() - 1);
}

void RayLogRecorder::camera_rays(std::span<const trace::RayRecord> placed, std::uint64_t, std::uint64_t) {
  for (const trace::RayRecord& r : placed) {
    const std::uint32_t v = add_visit(r);
    log_.entry.at(camera_index(r)) = v;
    live_[key(r)] = v;
  }
}

void RayLogRecorder::job(std::span<const trace::RayRecord> in, std::span<const trace::RayRecord> out) {
  if (in.empty()) return;
  const bool shadow = in.front().kind == trace::RayKind::Shadow;
  // The job's input visits, by the key an output finds its parent with: the path for a
  // RayIntersect job, (path, bounce) for a ShadowIntersect job.
  std::unordered_map<std::uint64_t, std::uint32_t> parent;
  parent.reserve(in.size());
  for (const trace::RayRecord& r : in) {
    const auto it = live_.find(key(r));
    if (it == live_.end()) throw std::runtime_error("ray log: a job's input ray was never handed to it");
    parent[shadow ? key(r) : camera_index(r)] = it->second;
    live_.erase(it);
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;  // (parent visit, child visit)
  edges.reserve(out.size());
  for (const trace::RayRecord& o : out) {
    const auto it = parent.find(shadow ? key(o) : camera_index(o));
    if (it == parent.end()) throw std::runtime_error("ray log: an output ray has no input ray of its path");
    const std::uint32_t w = add_visit(o);
    edges.emplace_back(it->second, w);
    live_[key(o)] = w;
  }
  std::stable_sort(edges.begin(), edges.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t i = 0; i < edges.size();) {
    RayVisit& p = log_.visits[edges[i].first];
    p.first = static_cast<std::uint32_t>(log_.children.size());
    std::size_t j = i;
    for (; j < edges.size() && edges[j].first == edges[i].first; ++j) log_.children.push_back(edges[j].second);
    if (j - i > 255) throw std::runtime_error("ray log: more than 255 rays from one visit");
    p.children = static_cast<std::uint8_t>(j - i);
    i = j;
  }
}

}  // namespace rayline::engine

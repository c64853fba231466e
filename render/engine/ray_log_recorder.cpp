#include "render/engine/ray_log_recorder.hpp"

#include <algorithm>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace rayline::engine {

void RayLogRecorder::begin(std::uint32_t width, std::uint32_t height, std::uint32_t spp, std::uint32_t cells) {
  log_ = RayLog{};
  log_.width = width, log_.height = height, log_.spp = spp, log_.cells = cells;
  pixels_ = std::uint64_t(width) * height;
  events_.clear();
  rays_.clear();
  finished_ = false;
}

std::uint64_t RayLogRecorder::id(const trace::RayRecord& r) const {
  if (r.bounce > 255) throw std::runtime_error("ray log: more than 255 bounces");
  const std::uint64_t camera = std::uint64_t(r.sample) * pixels_ + r.pixel;
  return (camera << 9) | (std::uint64_t(r.bounce) << 1) | std::uint64_t(r.kind);
}

void RayLogRecorder::camera_rays(std::span<const trace::RayRecord> placed) {
  events_.push_back({true, 0, static_cast<std::uint32_t>(placed.size())});
  for (const trace::RayRecord& r : placed) rays_.push_back({id(r), r.cell});
}

void RayLogRecorder::job(std::uint32_t cell, std::span<const std::uint64_t> in, std::span<const trace::RayRecord> out) {
  if (in.empty()) return;
  events_.push_back({false, static_cast<std::uint32_t>(in.size()), static_cast<std::uint32_t>(out.size())});
  for (std::uint64_t k : in) rays_.push_back({k, cell});
  for (const trace::RayRecord& r : out) rays_.push_back({id(r), r.cell});
}

const RayLog& RayLogRecorder::finish() {
  if (finished_) return log_;
  log_.entry.assign(pixels_ * log_.spp, RayLog::kNoVisit);
  std::unordered_map<std::uint64_t, std::uint32_t> live;  // ray -> its current visit
  auto add_visit = [&](const Rec& r) {
    if (log_.visits.size() >= RayLog::kNoVisit - 1) throw std::runtime_error("ray log: more than 2^32 visits");
    RayVisit v;
    v.cell = r.cell;
    v.bounce = static_cast<std::uint16_t>((r.key >> 1) & 0xFF);
    v.kind = static_cast<std::uint8_t>(r.key & 1);
    log_.visits.push_back(v);
    const auto id = static_cast<std::uint32_t>(log_.visits.size() - 1);
    live[r.key] = id;
    return id;
  };
  std::unordered_map<std::uint64_t, std::uint32_t> parent;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;  // (parent visit, child visit)
  std::size_t at = 0;
  for (const Event& e : events_) {
    if (e.camera) {
      for (std::uint32_t i = 0; i < e.out; ++i, ++at) log_.entry.at(rays_[at].key >> 9) = add_visit(rays_[at]);
      continue;
    }
    const bool shadow = (rays_[at].key & 1) != 0;
    // The job's input visits, by the key an output finds its parent with: the path for a
    // RayIntersect job, (path, bounce) for a ShadowIntersect job.
    parent.clear();
    for (std::uint32_t i = 0; i < e.in; ++i, ++at) {
      const auto it = live.find(rays_[at].key);
      if (it == live.end()) throw std::runtime_error("ray log: a job's input ray was never handed to it");
      parent[shadow ? rays_[at].key : rays_[at].key >> 9] = it->second;
      live.erase(it);
    }
    edges.clear();
    for (std::uint32_t i = 0; i < e.out; ++i, ++at) {
      const auto it = parent.find(shadow ? rays_[at].key : rays_[at].key >> 9);
      if (it == parent.end()) throw std::runtime_error("ray log: an output ray has no input ray of its path");
      const std::uint32_t p = it->second;
      edges.emplace_back(p, add_visit(rays_[at]));
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
  if (!live.empty()) throw std::runtime_error("ray log: rays still alive at the end of the render");
  std::deque<Event>().swap(events_);
  std::deque<Rec>().swap(rays_);
  finished_ = true;
  return log_;
}

}  // namespace rayline::engine

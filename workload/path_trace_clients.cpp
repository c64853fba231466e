#include "workload/path_trace_clients.hpp"

#include <algorithm>
#include <cmath>

namespace rayline {

std::uint64_t total(const RayCounts& c) {
  std::uint64_t t = 0;
  for (const auto& [k, n] : c) t += n;
  return t;
}

void normalize(RayCounts& c) {
  if (!std::is_sorted(c.begin(), c.end())) std::sort(c.begin(), c.end());  // (counts are mostly made in key order)
  std::size_t w = 0;
  for (std::size_t r = 0; r < c.size(); ++r) {
    if (c[r].second == 0) continue;
    if (w > 0 && c[w - 1].first == c[r].first) c[w - 1].second += c[r].second;
    else c[w++] = c[r];
  }
  c.resize(w);
}

void add_count(RayCounts& c, std::uint64_t key, std::uint64_t n) {
  if (n == 0) return;
  if (!c.empty() && c.back().first == key) c.back().second += n;
  else c.emplace_back(key, n);
}

void merge_into(RayCounts& into, const RayCounts& add) {
  if (add.empty()) return;
  if (into.empty() || into.back().first < add.front().first) {  // the usual case: later keys
    into.insert(into.end(), add.begin(), add.end());
    return;
  }
  // Merged into a buffer kept between calls, which then trades places with `into`'s.
  thread_local RayCounts out;
  out.clear();
  out.reserve(into.size() + add.size());
  std::size_t i = 0, j = 0;
  while (i < into.size() || j < add.size()) {
    if (j == add.size() || (i < into.size() && into[i].first < add[j].first)) out.push_back(into[i++]);
    else if (i == into.size() || add[j].first < into[i].first) out.push_back(add[j++]);
    else {
      out.emplace_back(into[i].first, into[i].second + add[j].second);
      ++i;
      ++j;
    }
  }
  into.swap(out);
}

RayCounts next_wave(const SceneProfile& p, std::uint32_t frame_uid, FrameState& f, bool per_tile) {
  RayCounts w;
  std::uint64_t rays = 0;
  const auto tiles = static_cast<std::uint64_t>(p.tiles());
  while (f.next_unit < f.units_total && (rays == 0 || rays < p.wave_rays)) {
    const int tile = static_cast<int>(f.next_unit % tiles);
    const std::uint64_t n = p.tile_pixels(tile);
    w.emplace_back(ray_key(frame_uid, per_tile ? tile : 0, 0), n);
    rays += n;
    ++f.next_unit;
  }
  normalize(w);
  return w;
}

std::uint64_t partial_tiles(std::uint64_t samples, int tiles) {
  if (samples == 0 || tiles <= 0) return 0;
  const double t = static_cast<double>(tiles);
  const double covered = t * -std::expm1(static_cast<double>(samples) * std::log1p(-1.0 / t));
  return std::min<std::uint64_t>(static_cast<std::uint64_t>(tiles), static_cast<std::uint64_t>(std::ceil(covered - 1e-9)));
}

}  // namespace rayline

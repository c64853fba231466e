#include "workload/twin_oracle.hpp"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <tuple>

namespace rayline {

bool ReplayOracle::entry(std::uint64_t i, TwinRay& r) {
  const std::uint32_t v = log_->entry[i];
  if (v == RayLog::kNoVisit) return false;
  const RayVisit& rv = log_->visits[v];
  r = TwinRay{v, rv.cell, rv.kind, static_cast<std::uint8_t>(rv.bounce)};
  return true;
}

void ReplayOracle::visit(const TwinRay& r, std::vector<TwinRay>& out) {
  const RayLog& log = *log_;
  const RayVisit& v = log.visits[r.visit];
  for (std::uint32_t k = 0; k < v.children; ++k) {
    const std::uint32_t w = log.children[v.first + k];
    const RayVisit& c = log.visits[w];
    out.push_back(TwinRay{w, c.cell, c.kind, static_cast<std::uint8_t>(c.bounce)});
  }
}

MarkovOracle::MarkovOracle(const RayLog& log, std::uint32_t width, std::uint32_t height, std::uint32_t spp,
                           std::uint64_t seed)
    : width_(width), height_(height), spp_(spp), cells_(log.cells), state_(seed * 0x9E3779B97F4A7C15ull + 1) {
  if (width == 0 || height == 0 || spp == 0) throw std::invalid_argument("markov twin: empty image");
  // Entry: per tile of the log's image, how many camera rays missed or entered each cell.
  entry_.assign(kTiles * kTiles, std::vector<std::uint64_t>(std::size_t(cells_) + 1, 0));
  const std::uint64_t pixels = std::uint64_t(log.width) * log.height;
  for (std::uint64_t i = 0; i < log.entry.size(); ++i) {
    const std::uint64_t px = i % pixels;
    const auto x = std::uint32_t(px % log.width), y = std::uint32_t(px / log.width);
    auto& t = entry_[std::size_t(y * kTiles / log.height) * kTiles + x * kTiles / log.width];
    const std::uint32_t v = log.entry[i];
    ++t[v == RayLog::kNoVisit ? 0 : std::size_t(log.visits[v].cell) + 1];
  }
  for (auto& t : entry_)
    for (std::size_t k = 1; k < t.size(); ++k) t[k] += t[k - 1];
  // Visits: per (cell, kind, bounce), how often each outcome happened (in a fixed order, so
  // the model and its samples do not depend on hashing).
  using OutcomeKey = std::tuple<std::uint8_t, std::uint8_t, std::uint8_t, std::uint32_t, std::uint8_t, std::uint8_t,
                                std::uint32_t>;
  std::map<std::uint64_t, std::map<OutcomeKey, std::uint64_t>> counts;
  for (const RayVisit& v : log.visits) {
    Outcome o;
    o.n = static_cast<std::uint8_t>(std::min<std::uint32_t>(v.children, 2));
    for (std::uint32_t k = 0; k < o.n; ++k) {
      const RayVisit& c = log.visits[log.children[v.first + k]];
      o.kind[k] = c.kind;
      o.bounce[k] = static_cast<std::uint8_t>(std::min<std::uint32_t>(c.bounce, 255));
      o.cell[k] = c.cell;
    }
    ++counts[key(v.cell, v.kind, static_cast<std::uint8_t>(std::min<std::uint32_t>(v.bounce, 255)))]
            [{o.n, o.kind[0], o.bounce[0], o.cell[0], o.kind[1], o.bounce[1], o.cell[1]}];
  }
  for (const auto& [k, outcomes] : counts) {
    State& s = states_[k];
    std::uint64_t sum = 0;
    for (const auto& [ok, n] : outcomes) {
      Outcome o;
      std::tie(o.n, o.kind[0], o.bounce[0], o.cell[0], o.kind[1], o.bounce[1], o.cell[1]) = ok;
      s.outcomes.push_back(o);
      s.cumulative.push_back(sum += n);
    }
  }
}

std::uint64_t MarkovOracle::next() {
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

bool MarkovOracle::entry(std::uint64_t i, TwinRay& r) {
  const std::uint64_t pixels = std::uint64_t(width_) * height_;
  const std::uint64_t px = i % pixels;
  const auto x = std::uint32_t(px % width_), y = std::uint32_t(px / width_);
  const auto& t = entry_[std::size_t(y * kTiles / height_) * kTiles + x * kTiles / width_];
  if (t.back() == 0) return false;
  const std::uint64_t u = below(t.back());
  const auto k = std::size_t(std::upper_bound(t.begin(), t.end(), u) - t.begin());
  if (k == 0) return false;  // missed the scene
  r = TwinRay{0, static_cast<std::uint32_t>(k - 1), 0, 0};
  return true;
}

void MarkovOracle::visit(const TwinRay& r, std::vector<TwinRay>& out) {
  const auto it = states_.find(key(r.cell, r.kind, r.bounce));
  if (it == states_.end()) return;  // never seen in the log: it ends
  const State& s = it->second;
  const std::uint64_t u = below(s.cumulative.back());
  const Outcome& o = s.outcomes[std::size_t(std::upper_bound(s.cumulative.begin(), s.cumulative.end(), u) - s.cumulative.begin())];
  for (std::uint8_t k = 0; k < o.n; ++k) out.push_back(TwinRay{0, o.cell[k], o.kind[k], o.bounce[k]});
}

}  // namespace rayline

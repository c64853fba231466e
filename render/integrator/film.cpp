#include "render/integrator/film.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace rayline::trace {

Film::Film(int width, int height)
    : width_(width), height_(height), sums_(std::size_t(width) * std::size_t(height) * 3, 0),
      samples_(std::size_t(width) * std::size_t(height), 0) {}

void Film::add(std::uint32_t pixel, scene::Float3 c) {
  for (int k = 0; k < 3; ++k) {
    float v = c[k];
    if (v == 0) continue;
    if (!std::isfinite(v) || v < 0) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    if (v > kMaxContribution) {
      v = kMaxContribution;
      clamped_.fetch_add(1, std::memory_order_relaxed);
    }
    const auto units = static_cast<std::int64_t>(std::llround(double(v) * kScale));
    if (journal_) {
      journal_entries_.push_back({pixel, std::uint32_t(k), units});
      continue;
    }
    std::atomic_ref<std::int64_t>(sums_[std::size_t(pixel) * 3 + std::size_t(k)]).fetch_add(units, std::memory_order_relaxed);
  }
}

void Film::apply(std::span<const FilmEntry> entries, std::uint64_t dropped, std::uint64_t clamped) {
  for (const FilmEntry& e : entries) {
    if (e.channel > 2) throw std::out_of_range("film journal: channel " + std::to_string(e.channel));
    std::atomic_ref<std::int64_t>(sums_.at(std::size_t(e.pixel) * 3 + e.channel)).fetch_add(e.units, std::memory_order_relaxed);
  }
  dropped_.fetch_add(dropped, std::memory_order_relaxed);
  clamped_.fetch_add(clamped, std::memory_order_relaxed);
}

std::vector<float> Film::resolve(int spp) const {
  std::vector<float> out(sums_.size());
  const double inv = 1.0 / (kScale * (spp > 0 ? spp : 1));
  for (std::size_t i = 0; i < sums_.size(); ++i) out[i] = static_cast<float>(double(sums_[i]) * inv);
  return out;
}

}  // namespace rayline::trace

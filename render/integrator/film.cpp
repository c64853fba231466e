#include "render/integrator/film.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace rayline::trace {

Film::Film(int width, int height)
    : width_(width), height_(height), sums_(std::size_t(width) * std::size_t(height) * 3, 0),
      samples_(std::size_t(width) * std::size_t(height), 0) {}

Film::Film(int width, int height, bool journal, std::uint32_t first, std::uint32_t count)
    : width_(width), height_(height), journal_(journal), window_first_(first),
      window_count_(count),
      sums_(std::size_t(window_count_) * 3, 0), samples_(window_count_, 0) {}

// Rounding half away from zero, as std::llround, for 0 <= v < 2^63: v - trunc(v) is exact.
static std::int64_t round_units(double v) {
  const auto t = static_cast<std::int64_t>(v);
  return v - double(t) >= 0.5 ? t + 1 : t;
}

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
    const std::int64_t units = round_units(double(v) * kScale);
    if (journal_) {
      journal_entries_.push_back({pixel, std::uint32_t(k), units});
      continue;
    }
    if (window_count_) {
      sums_[slot(pixel) * 3 + std::size_t(k)] += units;
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

void Film::merge(const Film& w) {
  for (std::uint32_t i = 0; i < w.window_count_; ++i) {
    const std::uint32_t p = w.window_first_ + i;
    for (std::size_t k = 0; k < 3; ++k)
      if (const std::int64_t u = w.sums_[std::size_t(i) * 3 + k])
        std::atomic_ref<std::int64_t>(sums_[std::size_t(p) * 3 + k]).fetch_add(u, std::memory_order_relaxed);
    if (const std::uint32_t n = w.samples_[i]) std::atomic_ref<std::uint32_t>(samples_[p]).fetch_add(n);
  }
  dropped_.fetch_add(w.dropped(), std::memory_order_relaxed);
  clamped_.fetch_add(w.clamped(), std::memory_order_relaxed);
}

std::vector<float> Film::resolve(int spp) const {
  std::vector<float> out(sums_.size());
  const double inv = 1.0 / (kScale * (spp > 0 ? spp : 1));
  for (std::size_t i = 0; i < sums_.size(); ++i) out[i] = static_cast<float>(double(sums_[i]) * inv);
  return out;
}

}  // namespace rayline::trace

// Order-independent accumulation ("Determinism"): every contribution is rounded
// once to 64-bit fixed point (2^-24 units) and added atomically. Integer addition is
// associative, so the sum — and the image — is bit-identical whatever the order in which
// threads, batches and blocks deliver their contributions.
#pragma once
#include <atomic>
#include <cstdint>
#include <span>
#include <vector>

#include "render/scene/geometry.hpp"

namespace rayline::trace {

// One contribution already in fixed point (a journal film's record).
struct FilmEntry {
  std::uint32_t pixel = 0;
  std::uint32_t channel = 0;
  std::int64_t units = 0;
};

class Film {
 public:
  static constexpr double kScale = 16777216.0;  // 2^24 units per unit radiance
  static constexpr float kMaxContribution = 1e6f;

  Film(int width, int height);
  // A journal: add() records each contribution, rounded exactly as a dense film rounds it,
  // instead of summing it (one E-job of a distributed render on another rank, whose
  // contributions travel back with the job's outputs, render/mpi/README.md). Used by one
  // thread; count_sample() is not for journals.
  static Film journal() { return Film(0, 0, true, 0, 0); }
  // A window: the contributions and samples of one camera job, whose camera rays cover
  // pixels [first, first + count) of the image, summed without atomics by the one
  // thread that runs the job, then added to `film` by merge() in one pass. Every
  // contribution is rounded as a dense film rounds it, so the sums are the same bit for bit.
  static Film window(const Film& film, std::uint32_t first, std::uint32_t count) {
    return Film(film.width_, film.height_, false, first, count);
  }
  // Adds a window's sums, samples and dropped / clamped counts (thread-safe).
  void merge(const Film& window);
  std::vector<FilmEntry> take_journal() { return std::move(journal_entries_); }
  // Adds a journal's records and its dropped / clamped counts (thread-safe): the sums are
  // those the contributions would have made here, bit for bit.
  void apply(std::span<const FilmEntry> entries, std::uint64_t dropped, std::uint64_t clamped);
  int width() const { return width_; }
  int height() const { return height_; }

  // Thread-safe. Non-finite or negative channels are dropped (and counted); values above
  // kMaxContribution are clamped (and counted).
  void add(std::uint32_t pixel, scene::Float3 radiance);
  // One more camera sample for `pixel` (conservation: every pixel gets exactly spp).
  void count_sample(std::uint32_t pixel) {
    if (window_count_) ++samples_[slot(pixel)];
    else std::atomic_ref<std::uint32_t>(samples_[pixel]).fetch_add(1);
  }

  std::uint32_t samples(std::uint32_t pixel) const { return samples_[pixel]; }
  std::uint64_t dropped() const { return dropped_.load(); }
  std::uint64_t clamped() const { return clamped_.load(); }
  // Linear RGB: the fixed-point sums divided by `spp`.
  std::vector<float> resolve(int spp) const;
  // The raw sums (tests compare these bit for bit).
  const std::vector<std::int64_t>& sums() const { return sums_; }

 private:
  Film(int width, int height, bool journal, std::uint32_t first, std::uint32_t count);
  // A window's slot of `pixel` (in [window_first_, window_first_ + window_count_)).
  std::size_t slot(std::uint32_t pixel) const { return pixel - window_first_; }
  int width_, height_;
  bool journal_ = false;
  std::uint32_t window_first_ = 0, window_count_ = 0;  // a window's pixels (count 0: not a window)
  std::vector<FilmEntry> journal_entries_;
  std::vector<std::int64_t> sums_;      // 3 per pixel
  std::vector<std::uint32_t> samples_;  // per pixel
  std::atomic<std::uint64_t> dropped_{0}, clamped_{0};
};

}  // namespace rayline::trace
